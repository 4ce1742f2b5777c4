// Names of pin modes as they appear in part files and settings.
#include "core/pin.h"

namespace gaugeloop {

std::string_view pin_mode_name(PinMode mode) {
  switch (mode) {
    case PinMode::kCX:
      return "c-x";
    case PinMode::kCXY:
      return "c-x-y";
  }
  return "unknown";
}

std::optional<PinMode> pin_mode_from_name(std::string_view name) {
  if (name == "c-x") return PinMode::kCX;
  if (name == "c-x-y") return PinMode::kCXY;
  return std::nullopt;
}

}  // namespace gaugeloop

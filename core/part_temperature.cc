// The part temperature's range, rounding and names.
#include "core/part_temperature.h"

#include <cmath>

#include "core/number_text.h"

namespace gaugeloop {

std::string_view part_temperature_source_name(PartTemperatureSource source) {
  switch (source) {
    case PartTemperatureSource::kPlc:
      return "plc";
    case PartTemperatureSource::kOperator:
      return "operator";
  }
  return "operator";
}

Result<double> checked_part_temperature_c(double temperature_c, std::string_view where) {
  if (!std::isfinite(temperature_c) || temperature_c < kPartTemperatureMinC || temperature_c > kPartTemperatureMaxC) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string(where) + " " + format_fixed(temperature_c, 1) +
                          ": not a part temperature; give the part's temperature in degrees Celsius, " +
                          format_fixed(kPartTemperatureMinC, 1) + " to " + format_fixed(kPartTemperatureMaxC, 1) +
                          " (21.4 for a part at 21.4 deg C), or leave it out when not measured");
  }
  const double rounded = std::round(temperature_c * 10.0) / 10.0;
  return rounded == 0.0 ? 0.0 : rounded;  // never -0.0
}

std::string part_temperature_c_text(double temperature_c) { return format_fixed(temperature_c, 1); }

}  // namespace gaugeloop

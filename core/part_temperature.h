// The part's temperature at measurement, as the PLC or the person measuring gives it: kept with
// the run and printed on its report, so that a shop can tell a warm part's error from a wrong
// table.
#pragma once

#include <string>
#include <string_view>

#include "core/result.h"

namespace gaugeloop {

// The range a part on the gauge can have, deg C. Beyond it the value is a fault of whoever
// wrote it (a PLC word left unset, a sign or a scale slipped), not a temperature.
inline constexpr double kPartTemperatureMinC = -40.0;
inline constexpr double kPartTemperatureMaxC = 150.0;

// Who gave the temperature: the PLC's handshake word, or a person (the command line's
// --part-temperature-c, the HTTP API's `part_temperature_c`).
enum class PartTemperatureSource { kPlc, kOperator };

// A temperature given for a run: within the range, rounded to 0.1 deg C
// (checked_part_temperature_c, decode_plc_part_temperature).
struct PartTemperature {
  double temperature_c = 0.0;
  PartTemperatureSource source = PartTemperatureSource::kOperator;
};

// "plc", "operator": the run's settings line part.temperature_source.
std::string_view part_temperature_source_name(PartTemperatureSource source);

// `temperature_c` rounded to 0.1 deg C (the PLC word's resolution, and a shop thermometer's).
// kInvalidInput naming `where` (an option, a field) when it is not a finite number within
// kPartTemperatureMinC..kPartTemperatureMaxC.
Result<double> checked_part_temperature_c(double temperature_c, std::string_view where);

// "21.4": the value as the run's settings keep it (one decimal).
std::string part_temperature_c_text(double temperature_c);

}  // namespace gaugeloop

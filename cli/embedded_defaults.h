// The sample part, its lift table and the NC templates (table and main program), built into
// the binary so that `gaugeloop demo` and `gaugeloop sim` need no files.
#pragma once

#include <string_view>

namespace gaugeloop::embedded {

extern const std::string_view kDemoPartToml;    // examples/intake_flat.toml
extern const std::string_view kDemoLiftCsv;     // examples/intake_flat.csv
extern const std::string_view kNcTemplate;      // examples/sinumerik/cam_table.spf
extern const std::string_view kNcMainTemplate;  // examples/sinumerik/cam_main.mpf
// A correction layer: the main program coupling X to the design table and the layer on SIM1.
extern const std::string_view kNcMainLayerTemplate;  // examples/sinumerik/cam_main_layer.mpf
// With a work speed program: the speed subprogram and the main program that calls it.
extern const std::string_view kNcSpeedTemplate;      // examples/sinumerik/cam_speed.spf
extern const std::string_view kNcMainSpeedTemplate;  // examples/sinumerik/cam_main_speed.mpf
// Crankpins: the Y table (C-X-Y) and the main programs coupling X (C-X) or X and Y (C-X-Y).
extern const std::string_view kPinYTableTemplate;  // examples/sinumerik/pin_y_table.spf
extern const std::string_view kPinMainTemplate;    // examples/sinumerik/pin_main.mpf
extern const std::string_view kPinMainCxTemplate;  // examples/sinumerik/pin_main_cx.mpf
// Gears: the main program coupling C to B, Z, Y and SIM1 and calling the stroke.
extern const std::string_view kGearMainTemplate;  // examples/sinumerik/gear_main.mpf

}  // namespace gaugeloop::embedded

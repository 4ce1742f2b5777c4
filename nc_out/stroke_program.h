// A gear's stroke program for a worm-wheel generating grinder: the worm strokes up Z through the
// spline points while the virtual axis SIM1, a leading axis of the work spindle C in the
// electronic gearbox, stands at each point where it puts the gear back in mesh with the worm
// (docs/gears.md). And the gearbox's coupling lines that make B, Z, Y and SIM1 lead C.
// Pure text: no I/O.
//
// Frame: machine frame of core/gear.h; Z in mm, SIM1 in degrees of C.
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

struct StrokeProgramPoint {
  double z_mm = 0.0;
  double sim_deg = 0.0;
};

// How the values are written: the control rounds linear positions to MD10200
// $MN_INT_INCR_PER_MM and rotary ones to MD10210 $MN_INT_INCR_PER_DEG, so the program says
// what the control will hold. SIM1's grid decides how finely C can be put back in mesh: at the
// control's default of 1000 increments per degree, 0.0005 deg (0.75 um at the pitch circle of a
// 172 mm gear); a gear grinder is usually set finer.
struct StrokeProgramFormat {
  double z_increments_per_mm = 10000.0;
  double sim_increments_per_deg = 1000.0;
  int z_decimals() const;
  int sim_decimals() const;
  double round_z_mm(double z) const;
  double round_sim_deg(double sim) const;
};

// The electronic gearbox with C following B, Z, Y and SIM1 (coupling type 1: the leading axes'
// setpoints), then switched on with each leading axis' factor as numerator and denominator:
//   EGDEF(C,B,1,Z,1,Y,1,SIM1,1)
//   EGON(C,"FINE",B,-1,71,Z,-0.266388852882,1,Y,0.717294043564,1,SIM1,1,1)
// B's factor is the whole ratio b_numerator / b_denominator (starts over teeth); Z's and Y's
// are degrees of C per mm, written with 12 decimals over 1.
struct GearboxFactors {
  int b_numerator = 0;
  int b_denominator = 1;
  double z_deg_per_mm = 0.0;
  double y_deg_per_mm = 0.0;
};
std::string render_gearbox_coupling(const GearboxFactors& factors);

// The stroke subprogram: header lines (`; gaugeloop key: value`: kind "gear stroke", `header` in order of key, then
// the point count, the largest |SIM1| and the body's FNV-1a 64 checksum), then the body:
//   FGROUP(Z)                        ; the feed is along Z; SIM1 moves with it
//   G1 G90 Z-15.0000 SIM1=0.001 F300
//   Z-14.0000 SIM1=0.002
//   ...
// and M17. kInvalidInput for fewer than 2 points, Z not increasing, a value not finite, or a
// feed not in (0, 100000] mm/min.
Result<std::string> render_stroke_program(std::string_view program_name,
                                          const std::map<std::string, std::string>& header,
                                          const std::vector<StrokeProgramPoint>& points, double feed_mm_per_min,
                                          const StrokeProgramFormat& format = {});

// Whether `text` is a stroke program: its header (before the first block) holds
// `; gaugeloop kind: gear stroke`, as render_stroke_program writes it. A curve-table program is not.
bool is_stroke_program(std::string_view text);

// A stroke program read back.
struct ParsedStrokeProgram {
  std::vector<StrokeProgramPoint> points;
  std::vector<int> point_lines;  // 1-based
  std::map<std::string, std::string> header;
  std::string body_checksum;  // computed over the body as read
};

// Reads what render_stroke_program writes: blocks with Z and SIM1 (SIM1 modal), G1, G90, F,
// FGROUP(Z), block numbers and comments; anything else is refused naming the line, as is a Z
// that does not increase. kRefused when the body does not match the header's checksum or point
// count (edited by hand); kInvalidInput for a program without them.
Result<ParsedStrokeProgram> parse_stroke_program(std::string_view text, std::string_view file_name);

}  // namespace gaugeloop

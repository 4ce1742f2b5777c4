// The work speed on the control: a speed program (core/work_speed.h) written as a feed
// profile in C, one turn per subprogram call, and read back to say what speed the control
// will run.
//
// Frame: machine frame. C (work spindle) in degrees, 0 where the X table's C0 is; speeds in
// rpm, feeds in deg/min (G94 with C the only axis of the feed: F = 360 * rpm).
//
// Form (docs/nc_output.md, "Variable work speed on the control"): blocks
//   G1 G64 G94 FLIN C=IC(5.000) F21600.0
//   C=IC(5.000) F18000.0
//   ...
// G64 (continuous-path mode) so that C does not stop at block ends. Each block turns C by its
// increment; with FLIN the control takes the feed linearly over the block's path from the
// feed at its start (the previous block's F) to its own F. So the speed
// the control runs is piecewise linear in C through the blocks' end points; over a turn, the
// first block starts from the last block's F (the speed at C360 is the speed at C0), which
// holds for every turn but the first, whose first block starts from the speed C had.
//
// Speed error: the largest |speed run - program| / program over the program's C positions, in
// percent. Timing error: how far C runs ahead of (+) or behind (-) the program at the same time
// since C0, to first order (time difference times the program's speed), degrees. Neither
// touches the form: the X table is a function of C position, not of time.
//
// Errors: kInvalidInput for a speed program or a setting out of range (naming the C degree or
// the setting); kRefused when no profile keeps the bound at the control's block rate.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "core/work_speed.h"

namespace gaugeloop {

// Checks a speed program: c_step_deg finite and positive, dividing 360 (to 1e-9 turns), one
// speed per step, every speed finite and positive. The message names the C degree.
Status validate_work_speed_program(const WorkSpeedProgram& program);

// One feed block: C turns from the previous block's end (0 for the first) to c_end_deg, the
// feed reaching feed_deg_per_min at the end. The last block ends at C360.
struct SpeedBlock {
  double c_end_deg = 0.0;
  double feed_deg_per_min = 0.0;
};

struct SpeedProfileFormat {
  int c_decimals = 3;     // 0.001 deg
  int feed_decimals = 1;  // 0.1 deg/min: 0.0003 rpm
};

struct SpeedProfileSettings {
  double bound_percent = 2.0;  // largest speed error allowed: the grinding-point speed, and h_eq, within 2 %
  double max_step_deg = 30.0;  // no block turns C further than this
  // No block shorter than this at the speed it runs: the control must prepare blocks faster
  // than it runs them (a few interpolation cycles each; check MD10050/MD10070 on the control).
  double min_block_time_s = 0.008;
};

// What the control runs from a profile, against the program.
struct SpeedProfileError {
  double max_speed_error_percent = 0.0;
  double speed_error_at_c_deg = 0.0;
  double max_timing_error_deg = 0.0;  // signed: + C ahead of the program
  double timing_error_at_c_deg = 0.0;
  double turn_time_s = 0.0;          // one turn as written
  double program_turn_time_s = 0.0;  // one turn of the program (linear in C between its steps)
  double shortest_block_s = 0.0;
  double shortest_block_at_c_deg = 0.0;  // where that block starts
};

// A profile as it will be written: c_end_deg rounded to the format's C decimals (strictly
// increasing, the last 360), feeds rounded to its feed decimals.
struct SpeedProfile {
  std::vector<SpeedBlock> blocks;
  std::string writer;  // how the blocks were chosen, for reports
  SpeedProfileError error;

  int block_count() const { return static_cast<int>(blocks.size()); }
};

// The speed error, timing error and block times of `blocks` against `program`.
// kInvalidInput for an invalid program or blocks that do not run from C0 to C360 with
// positive feeds.
Result<SpeedProfileError> speed_profile_error(const WorkSpeedProgram& program, const std::vector<SpeedBlock>& blocks);

// The fewest blocks on the program's C positions such that every block keeps the speed error
// bound at the steps it spans, turns C at most max_step_deg and runs at least
// min_block_time_s. kRefused, naming the C degrees, where no such block goes on: the speed
// changes faster there than blocks that keep the bound can be run.
Result<SpeedProfile> write_speed_profile(const WorkSpeedProgram& program, const SpeedProfileSettings& settings = {},
                                         const SpeedProfileFormat& format = {});

// The blocks as NC text: the first carries G1 G64 G94 FLIN, each block
// C=IC(increment) X=IC(R1*increment/360) F(feed): increments the differences of the rounded
// end positions (so they add up to 360 exactly), and X fed its share of R1, the infeed per
// turn the main program sets before each call (nc_out/infeed.h); R1=0 feeds nothing.
// Blocks separated by newlines, none after the last.
std::string render_speed_blocks(const std::vector<SpeedBlock>& blocks, const SpeedProfileFormat& format = {});

// Where a speed program comes from, for its header.
struct SpeedProvenance {
  std::int64_t run_id = 0;
  std::int64_t table_version = 0;  // the X table it was written beside; 0: not known
};

// Header comment lines `; gaugeloop <key>: <value>`: run_id, table_version, speed_form
// (feed_flin), block_count, speed_error_percent, speed_error_at_c_deg, timing_error_deg,
// turn_time_s, program_turn_time_s, shortest_block_ms, writer, body_checksum_fnv1a64 (as the
// table's, over the speed blocks' lines). Joined with "\n", none after the last.
std::string render_speed_header(const SpeedProfile& profile, const SpeedProvenance& provenance, std::string_view body);

// Renders the speed template with `values` plus speed_header, speed_blocks and block_count,
// then reads the result back (parse_speed_program) and refuses (kInvalidInput, naming the
// template) unless it gives exactly the profile's blocks with a matching checksum.
Result<std::string> render_speed_program(std::string_view template_text, std::string_view template_name,
                                         std::map<std::string, std::string> values, const SpeedProfile& profile,
                                         const SpeedProvenance& provenance, const SpeedProfileFormat& format = {});

// A speed program read back.
struct ParsedSpeedProgram {
  std::vector<SpeedBlock> blocks;  // end positions: the running sum of the increments
  std::vector<int> block_lines;    // 1-based line of each block
  std::map<std::string, std::string> header;
  std::string body_checksum;  // computed over the blocks' lines as read
  // Every block feeds X by its share of R1 (X=IC(R1*<its turn>/360)): one call feeds R1.
  bool overlaid_infeed = false;
};

// Parses a speed subprogram: comment lines, blank lines, the feed blocks (an optional block
// number, G1, G64, G94, FLIN, C=IC(value), X=IC(R1*value/360) with the block's own turn (in
// every block or in none), F value or F=value; every block needs C and F; G1,
// G64, G94 and FLIN set by the first), then M17 or RET. Anything else is refused with its line: gaugeloop
// cannot say what the control would make of it. The increments must add up to 360 (0.0005 deg).
Result<ParsedSpeedProgram> parse_speed_program(std::string_view text, std::string_view file_name);

// kRefused if the blocks do not match the header's checksum or block count (edited by hand);
// kInvalidInput without a checksum line.
Status verify_speed_checksum(const ParsedSpeedProgram& program, std::string_view file_name);

// What the control will run from `text`, against `program`: parse, checksum, then
// speed_profile_error of the blocks read. kRefused, naming the file and C, if the speed error
// read back exceeds bound_percent.
Result<SpeedProfileError> check_speed_program(std::string_view text, std::string_view file_name,
                                              const WorkSpeedProgram& program, double bound_percent);

}  // namespace gaugeloop

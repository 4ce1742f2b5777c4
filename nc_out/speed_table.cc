// Writing the work speed as a FLIN feed profile in C, and reading it back.
#include "nc_out/speed_table.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <optional>

#include "core/number_text.h"
#include "nc_out/infeed.h"
#include "nc_out/nc_template.h"
#include "nc_out/nc_text.h"
#include "nc_out/table_program.h"

namespace gaugeloop {
namespace {

using nc_text::round_to;

using nc_text::lines_of;
using nc_text::parse_number;
using nc_text::trim;
using nc_text::upper;

constexpr double kFullTurnDeg = 360.0;
constexpr double kTurnTolDeg = 0.0005;  // half the default C resolution

std::string deg_text(double c_deg) { return "C" + format_fixed(c_deg, 3); }

// Time to run `length_deg` with the feed linear in path from v0 to v1 (deg/s, both positive):
// dt = ds / v(s), v linear in s, so t = L ln(v1 / v0) / (v1 - v0).
double linear_feed_time_s(double length_deg, double v0_deg_per_s, double v1_deg_per_s) {
  const double dv = v1_deg_per_s - v0_deg_per_s;
  if (std::abs(dv) <= 1e-12 * v0_deg_per_s) return length_deg / v0_deg_per_s;
  return length_deg * std::log(v1_deg_per_s / v0_deg_per_s) / dv;
}

double rpm_to_deg_per_s(double rpm) { return rpm * 6.0; }

// The program's speed at grid index k, periodic.
double program_rpm(const WorkSpeedProgram& p, size_t k) { return p.speed_rpm[k % p.speed_rpm.size()]; }

Status validate_blocks(const std::vector<SpeedBlock>& blocks) {
  if (blocks.empty()) return make_error(ErrorCode::kInvalidInput, "a speed profile needs at least one block");
  double last = 0.0;
  for (size_t k = 0; k < blocks.size(); ++k) {
    const SpeedBlock& b = blocks[k];
    if (!std::isfinite(b.c_end_deg) || b.c_end_deg <= last) {
      return make_error(ErrorCode::kInvalidInput, "speed block " + std::to_string(k + 1) + " ends at " +
                                                      deg_text(b.c_end_deg) + ", not beyond " + deg_text(last));
    }
    if (!std::isfinite(b.feed_deg_per_min) || b.feed_deg_per_min <= 0.0) {
      return make_error(ErrorCode::kInvalidInput,
                        "speed block " + std::to_string(k + 1) + " ending at " + deg_text(b.c_end_deg) + " has feed " +
                            format_fixed(b.feed_deg_per_min, 1) + " deg/min: must be finite and positive");
    }
    last = b.c_end_deg;
  }
  if (std::abs(last - kFullTurnDeg) > kTurnTolDeg) {
    return make_error(ErrorCode::kInvalidInput,
                      "the speed blocks turn C by " + format_fixed(last, 4) + " deg, not one turn (360)");
  }
  return {};
}

// What the control runs: the speed (deg/s) at `c_deg` and the time since C0 to reach it.
struct RunPoint {
  double speed_deg_per_s = 0.0;
  double time_s = 0.0;
};

class ProfileRun {
 public:
  explicit ProfileRun(const std::vector<SpeedBlock>& blocks) : blocks_(blocks) {
    double t = 0.0;
    for (size_t k = 0; k < blocks_.size(); ++k) {
      start_time_s_.push_back(t);
      t += linear_feed_time_s(length(k), v_start(k), v_end(k));
    }
    turn_time_s_ = t;
  }
  double c_start(size_t k) const { return k == 0 ? 0.0 : blocks_[k - 1].c_end_deg; }
  double length(size_t k) const { return blocks_[k].c_end_deg - c_start(k); }
  // The feed at a block's start is the previous block's F; the first block's, the last's.
  double v_start(size_t k) const {
    return (k == 0 ? blocks_.back().feed_deg_per_min : blocks_[k - 1].feed_deg_per_min) / 60.0;
  }
  double v_end(size_t k) const { return blocks_[k].feed_deg_per_min / 60.0; }
  double block_time_s(size_t k) const { return linear_feed_time_s(length(k), v_start(k), v_end(k)); }
  double turn_time_s() const { return turn_time_s_; }

  RunPoint at(double c_deg) const {
    size_t k = 0;
    while (k + 1 < blocks_.size() && c_deg >= blocks_[k].c_end_deg) ++k;
    const double s = std::clamp(c_deg - c_start(k), 0.0, length(k));
    const double v = v_start(k) + (v_end(k) - v_start(k)) * s / length(k);
    return {v, start_time_s_[k] + linear_feed_time_s(s, v_start(k), v)};
  }

 private:
  const std::vector<SpeedBlock>& blocks_;
  std::vector<double> start_time_s_;
  double turn_time_s_ = 0.0;
};

}  // namespace

Status validate_work_speed_program(const WorkSpeedProgram& program) {
  const double step = program.c_step_deg;
  if (!std::isfinite(step) || step <= 0.0 || step > kFullTurnDeg) {
    return make_error(ErrorCode::kInvalidInput, "speed program: c_step_deg " + format_fixed(step, 6) +
                                                    " must be a positive step of at most 360 deg");
  }
  const double count = kFullTurnDeg / step;
  const double whole = std::round(count);
  if (std::abs(count - whole) > 1e-9 * whole) {
    return make_error(ErrorCode::kInvalidInput, "speed program: c_step_deg " + format_fixed(step, 6) +
                                                    " does not divide 360; choose a step such as 1, 0.5 or 0.25 deg");
  }
  const auto n = static_cast<size_t>(whole);
  if (program.speed_rpm.size() != n) {
    return make_error(ErrorCode::kInvalidInput, "speed program: " + std::to_string(program.speed_rpm.size()) +
                                                    " speeds for c_step_deg " + format_fixed(step, 6) + ": expected " +
                                                    std::to_string(n) + " (one per step from C0)");
  }
  for (size_t k = 0; k < n; ++k) {
    const double v = program.speed_rpm[k];
    if (!std::isfinite(v) || v <= 0.0) {
      return make_error(ErrorCode::kInvalidInput,
                        "speed program: the speed at " + deg_text(static_cast<double>(k) * step) + " is " +
                            format_fixed(v, 3) + " rpm; every speed must be finite and positive");
    }
  }
  return {};
}

Result<SpeedProfileError> speed_profile_error(const WorkSpeedProgram& program, const std::vector<SpeedBlock>& blocks) {
  if (Status s = validate_work_speed_program(program); !s) return s.error();
  if (Status s = validate_blocks(blocks); !s) return s.error();
  const ProfileRun run(blocks);
  SpeedProfileError e;
  e.turn_time_s = run.turn_time_s();
  e.shortest_block_s = run.block_time_s(0);
  for (size_t k = 1; k < blocks.size(); ++k) {
    if (run.block_time_s(k) < e.shortest_block_s) {
      e.shortest_block_s = run.block_time_s(k);
      e.shortest_block_at_c_deg = run.c_start(k);
    }
  }
  // The program between its steps: linear in C, as a FLIN profile through every step would be.
  const size_t n = program.speed_rpm.size();
  double program_time_s = 0.0;
  double worst_timing = -1.0;
  for (size_t k = 0; k < n; ++k) {
    const double c = static_cast<double>(k) * program.c_step_deg;
    const double v_program = rpm_to_deg_per_s(program_rpm(program, k));
    const RunPoint p = run.at(c);
    const double speed_error = std::abs(p.speed_deg_per_s - v_program) / v_program * 100.0;
    if (speed_error > e.max_speed_error_percent) {
      e.max_speed_error_percent = speed_error;
      e.speed_error_at_c_deg = c;
    }
    // Written faster reaches C sooner: C is ahead of the program by the time gained at its speed.
    const double timing_deg = (program_time_s - p.time_s) * v_program;
    if (std::abs(timing_deg) > worst_timing) {
      worst_timing = std::abs(timing_deg);
      e.max_timing_error_deg = timing_deg;
      e.timing_error_at_c_deg = c;
    }
    program_time_s += linear_feed_time_s(program.c_step_deg, v_program, rpm_to_deg_per_s(program_rpm(program, k + 1)));
  }
  e.program_turn_time_s = program_time_s;
  return e;
}

Result<SpeedProfile> write_speed_profile(const WorkSpeedProgram& program, const SpeedProfileSettings& settings,
                                         const SpeedProfileFormat& format) {
  if (Status s = validate_work_speed_program(program); !s) return s.error();
  if (!std::isfinite(settings.bound_percent) || settings.bound_percent <= 0.0) {
    return make_error(ErrorCode::kInvalidInput,
                      "speed profile: bound_percent " + format_fixed(settings.bound_percent, 3) + " must be positive");
  }
  if (!std::isfinite(settings.max_step_deg) || settings.max_step_deg < program.c_step_deg) {
    return make_error(ErrorCode::kInvalidInput,
                      "speed profile: max_step_deg " + format_fixed(settings.max_step_deg, 3) +
                          " must be at least the program's step " + format_fixed(program.c_step_deg, 3));
  }
  if (!std::isfinite(settings.min_block_time_s) || settings.min_block_time_s < 0.0) {
    return make_error(
        ErrorCode::kInvalidInput,
        "speed profile: min_block_time_s " + format_fixed(settings.min_block_time_s, 4) + " must be zero or positive");
  }
  if (format.c_decimals < 0 || format.c_decimals > 6 || format.feed_decimals < 0 || format.feed_decimals > 4) {
    return make_error(ErrorCode::kInvalidInput, "speed profile: C decimals 0..6 and feed decimals 0..4");
  }
  const size_t n = program.speed_rpm.size();
  const double step = program.c_step_deg;
  const auto max_steps = static_cast<size_t>(std::floor(settings.max_step_deg / step + 1e-9));
  auto c_at = [&](size_t j) { return round_to(static_cast<double>(j) * step, format.c_decimals); };
  auto feed_at = [&](size_t j) { return round_to(program_rpm(program, j) * kFullTurnDeg, format.feed_decimals); };
  // Does one block from step i to step j keep the bound at every step it spans?
  auto keeps_bound = [&](size_t i, size_t j) {
    const double f0 = feed_at(i);
    const double f1 = feed_at(j);
    for (size_t k = i; k <= j; ++k) {
      const double f = f0 + (f1 - f0) * (c_at(k) - c_at(i)) / (c_at(j) - c_at(i));
      const double target = program_rpm(program, k) * kFullTurnDeg;
      if (std::abs(f - target) / target * 100.0 > settings.bound_percent) return false;
    }
    return true;
  };
  auto block_time_s = [&](size_t i, size_t j) {
    return linear_feed_time_s(c_at(j) - c_at(i), feed_at(i) / 60.0, feed_at(j) / 60.0);
  };
  // Fewest blocks from C0 to C360 over the program's steps, every block keeping the bound, at
  // most max_step_deg wide and at least min_block_time_s long (shortest path over the steps:
  // a greedy reach from C0 can leave a sliver of a block at the end of the turn).
  constexpr size_t kUnreached = static_cast<size_t>(-1);
  std::vector<size_t> blocks_to(n + 1, kUnreached);
  std::vector<size_t> from(n + 1, 0);
  blocks_to[0] = 0;
  size_t furthest = 0;
  for (size_t j = 1; j <= n; ++j) {
    for (size_t i = j - 1; i + max_steps >= j; --i) {
      if (blocks_to[i] != kUnreached && blocks_to[i] + 1 < blocks_to[j] && keeps_bound(i, j) &&
          block_time_s(i, j) >= settings.min_block_time_s) {
        blocks_to[j] = blocks_to[i] + 1;
        from[j] = i;
      }
      if (i == 0) break;
    }
    if (blocks_to[j] != kUnreached) furthest = j;
  }
  if (blocks_to[n] == kUnreached) {
    // Say where it fails: the widest block within the bound from the last step reached.
    size_t best = furthest;
    for (size_t j = furthest + 1; j <= n && j - furthest <= max_steps && keeps_bound(furthest, j); ++j) best = j;
    if (best == furthest) {
      return make_error(ErrorCode::kRefused, "speed profile: even one step from " + deg_text(c_at(furthest)) +
                                                 " breaks the speed bound of " +
                                                 format_fixed(settings.bound_percent, 3) +
                                                 " % (feed rounding); raise the feed decimals");
    }
    return make_error(ErrorCode::kRefused,
                      "speed profile: the speed changes from " + format_fixed(program_rpm(program, furthest), 2) +
                          " rpm at " + deg_text(c_at(furthest)) + " to " + format_fixed(program_rpm(program, best), 2) +
                          " rpm at " + deg_text(c_at(best)) + " faster than the control's blocks can follow: the " +
                          "longest block within " + format_fixed(settings.bound_percent, 3) + " % from there runs " +
                          format_fixed(block_time_s(furthest, best) * 1000.0, 1) +
                          " ms, under the shortest block time " + format_fixed(settings.min_block_time_s * 1000.0, 1) +
                          " ms; smooth the speed program there or raise the speed error bound");
  }
  SpeedProfile profile;
  for (size_t j = n; j > 0; j = from[j]) profile.blocks.push_back({c_at(j), feed_at(j)});
  std::reverse(profile.blocks.begin(), profile.blocks.end());
  Result<SpeedProfileError> e = speed_profile_error(program, profile.blocks);
  if (!e) return e.error();
  profile.error = *e;
  profile.writer = "flin fewest blocks " + format_fixed(settings.bound_percent, 3) + " %";
  return profile;
}

std::string render_speed_blocks(const std::vector<SpeedBlock>& blocks, const SpeedProfileFormat& format) {
  std::string out;
  double last = 0.0;
  for (size_t k = 0; k < blocks.size(); ++k) {
    const double end = round_to(blocks[k].c_end_deg, format.c_decimals);
    if (k > 0) out += '\n';
    if (k == 0) out += "G1 G64 G94 FLIN ";
    const std::string turn = format_fixed(end - last, format.c_decimals);
    // The overlaid infeed: the main program sets the parameter to the infeed per turn before
    // each call (render_speed_infeed_blocks), each block feeds its share of it.
    out += "C=IC(" + turn + ") X=IC(" + std::string(kSpeedInfeedParameter) + "*" + turn + "/360) F" +
           format_fixed(blocks[k].feed_deg_per_min, format.feed_decimals);
    last = end;
  }
  return out;
}

std::string render_speed_header(const SpeedProfile& profile, const SpeedProvenance& provenance, std::string_view body) {
  std::string out;
  auto line = [&out](std::string_view key, const std::string& value) { append_header_line(out, key, value); };
  const SpeedProfileError& e = profile.error;
  line("run_id", std::to_string(provenance.run_id));
  line("table_version", std::to_string(provenance.table_version));
  line("speed_form", "feed_flin");
  line("block_count", std::to_string(profile.block_count()));
  line("speed_error_percent", format_fixed(e.max_speed_error_percent, 3));
  line("speed_error_at_c_deg", format_fixed(e.speed_error_at_c_deg, 3));
  line("timing_error_deg", format_signed_fixed(e.max_timing_error_deg, 3));
  line("turn_time_s", format_fixed(e.turn_time_s, 4));
  line("program_turn_time_s", format_fixed(e.program_turn_time_s, 4));
  line("shortest_block_ms", format_fixed(e.shortest_block_s * 1000.0, 1));
  line("writer", profile.writer);
  line("body_checksum_fnv1a64", table_body_checksum(body));
  return out;
}

Result<std::string> render_speed_program(std::string_view template_text, std::string_view template_name,
                                         std::map<std::string, std::string> values, const SpeedProfile& profile,
                                         const SpeedProvenance& provenance, const SpeedProfileFormat& format) {
  if (Status s = validate_blocks(profile.blocks); !s) return s.error();
  const std::string body = render_speed_blocks(profile.blocks, format);
  values["speed_blocks"] = body;
  values["speed_header"] = render_speed_header(profile, provenance, body);
  values["block_count"] = std::to_string(profile.block_count());
  Result<std::string> text = render_nc_template(template_text, template_name, values);
  if (!text) return text.error();
  auto refuse = [&](const std::string& why) {
    return make_error(ErrorCode::kInvalidInput, std::string(template_name) +
                                                    ": the rendered speed program does not read back as the profile "
                                                    "written (" +
                                                    why +
                                                    "); put {{speed_header}} and {{speed_blocks}} on lines of their "
                                                    "own, with only comments around them and M17 at the end");
  };
  Result<ParsedSpeedProgram> back = parse_speed_program(*text, template_name);
  if (!back) return refuse(back.error().message);
  if (Status s = verify_speed_checksum(*back, template_name); !s) return refuse(s.error().message);
  if (back->blocks.size() != profile.blocks.size()) return refuse("block count differs");
  for (size_t k = 0; k < back->blocks.size(); ++k) {
    const double c_res = 0.5 * std::pow(10.0, -format.c_decimals);
    const double f_res = 0.5 * std::pow(10.0, -format.feed_decimals);
    if (std::abs(back->blocks[k].c_end_deg - profile.blocks[k].c_end_deg) > c_res + 1e-9 ||
        std::abs(back->blocks[k].feed_deg_per_min - profile.blocks[k].feed_deg_per_min) > f_res + 1e-9) {
      return refuse("line " + std::to_string(back->block_lines[k]) + " differs from block " + std::to_string(k + 1));
    }
  }
  return text;
}

Result<ParsedSpeedProgram> parse_speed_program(std::string_view text, std::string_view file_name) {
  const std::vector<std::string_view> lines = lines_of(text);
  auto fail = [&](size_t index, const std::string& why) {
    return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ":" + std::to_string(index + 1) + ": " + why);
  };
  ParsedSpeedProgram p;
  bool g1 = false;
  bool g64 = false;
  bool g94 = false;
  bool flin = false;
  bool ended = false;
  double c_end = 0.0;
  std::optional<size_t> first_block;
  size_t last_block = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string_view l = trim(lines[i]);
    if (read_header_line(l, p.header)) continue;
    std::string_view code = l.substr(0, l.find(';'));
    std::vector<std::string_view> words;
    while (true) {
      code = trim(code);
      if (code.empty()) break;
      size_t end = 0;
      while (end < code.size() && !std::isspace(static_cast<unsigned char>(code[end]))) ++end;
      words.push_back(code.substr(0, end));
      code = code.substr(end);
    }
    if (words.empty()) continue;
    if (ended) return fail(i, "a block after M17: the speed subprogram ends with its blocks");
    std::optional<double> increment;
    std::optional<double> feed;
    std::optional<double> share;
    for (size_t w = 0; w < words.size(); ++w) {
      const std::string u = upper(words[w]);
      if (w == 0 && u.size() > 1 && u[0] == 'N' && std::isdigit(static_cast<unsigned char>(u[1]))) continue;
      if (u == "G1" || u == "G01") {
        g1 = true;
      } else if (u == "G64") {
        g64 = true;
      } else if (u == "G94") {
        g94 = true;
      } else if (u == "FLIN") {
        flin = true;
      } else if (u == "M17" || u == "RET") {
        if (words.size() != w + 1 || increment || feed) return fail(i, "M17 belongs on a block of its own");
        ended = true;
      } else if (u.rfind("C=IC(", 0) == 0 && u.back() == ')') {
        increment = parse_number(std::string_view(u).substr(5, u.size() - 6));
        if (!increment || *increment <= 0.0)
          return fail(i, "'" + std::string(words[w]) + "' is not a positive turn of C");
      } else if (u.rfind("X=IC(" + std::string(kSpeedInfeedParameter) + "*", 0) == 0 && u.size() > 10 &&
                 u.compare(u.size() - 5, 5, "/360)") == 0) {
        // The overlaid infeed's share of this block: its own turn of C over 360.
        const std::size_t from = 6 + kSpeedInfeedParameter.size();
        share = parse_number(std::string_view(u).substr(from, u.size() - 5 - from));
        if (!share) return fail(i, "'" + std::string(words[w]) + "' is not X=IC(R1*<turn>/360)");
      } else if (u.size() > 1 && u[0] == 'F') {
        feed = parse_number(std::string_view(u).substr(u[1] == '=' ? 2 : 1));
        if (!feed || *feed <= 0.0) return fail(i, "'" + std::string(words[w]) + "' is not a positive feed");
      } else {
        return fail(i, "'" + std::string(words[w]) +
                           "' is not part of a speed profile (G1 G64 G94 FLIN C=IC(..) F..): gaugeloop cannot say what "
                           "the control would make of it");
      }
    }
    if (ended) continue;
    if (!increment || !feed) {
      return fail(i, "every speed block needs C=IC(..) and F..; gaugeloop writes both on each block");
    }
    if (!g1 || !g64 || !g94 || !flin) return fail(i, "the first speed block must set G1 G64 G94 FLIN");
    // Every block feeds its own share of the infeed, or none does: a turn that fed by more or
    // less than R1 would leave the part off size.
    if (share && std::abs(*share - *increment) > 1e-9) {
      return fail(i, "the block turns C by " + format_fixed(*increment, 3) + " deg but feeds X by R1*" +
                         format_fixed(*share, 3) + "/360; each block feeds its own share of the turn's infeed");
    }
    if (!first_block) {
      p.overlaid_infeed = share.has_value();
    } else if (p.overlaid_infeed != share.has_value()) {
      return fail(i, "some speed blocks feed X by R1 and some do not; a turn would not feed R1 in all");
    }
    if (!first_block) first_block = i;
    c_end += *increment;
    p.blocks.push_back({c_end, *feed});
    p.block_lines.push_back(static_cast<int>(i + 1));
    last_block = i;
  }
  if (!first_block) {
    return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ": no speed blocks (C=IC(..) F..)");
  }
  if (!ended) return fail(lines.size() - 1, "the speed subprogram does not end with M17");
  if (std::abs(c_end - kFullTurnDeg) > kTurnTolDeg) {
    return fail(last_block, "the speed blocks turn C by " + format_fixed(c_end, 4) +
                                " deg; one call must be one turn (360 deg) so that every call starts at C0");
  }
  p.blocks.back().c_end_deg = kFullTurnDeg;
  std::string body;
  for (size_t i = *first_block; i <= last_block; ++i) {
    if (i > *first_block) body += '\n';
    body += lines[i];
  }
  p.body_checksum = table_body_checksum(body);
  return p;
}

Status verify_speed_checksum(const ParsedSpeedProgram& program, std::string_view file_name) {
  const auto sum = program.header.find("body_checksum_fnv1a64");
  if (sum == program.header.end()) {
    return make_error(
        ErrorCode::kInvalidInput,
        std::string(file_name) + ": no body_checksum_fnv1a64 in the header: not a gaugeloop speed program");
  }
  const int first = program.block_lines.empty() ? 0 : program.block_lines.front();
  const int last = program.block_lines.empty() ? 0 : program.block_lines.back();
  if (sum->second != program.body_checksum) {
    return make_error(ErrorCode::kRefused, std::string(file_name) + ": the speed blocks (lines " +
                                               std::to_string(first) + " to " + std::to_string(last) +
                                               ") do not match their checksum: edited by hand since gaugeloop wrote "
                                               "them; push the speed program again");
  }
  const auto count = program.header.find("block_count");
  if (count != program.header.end() && count->second != std::to_string(program.blocks.size())) {
    return make_error(ErrorCode::kRefused, std::string(file_name) + ": " + std::to_string(program.blocks.size()) +
                                               " speed blocks, the header says " + count->second +
                                               ": edited by hand; push the speed program again");
  }
  return {};
}

Result<SpeedProfileError> check_speed_program(std::string_view text, std::string_view file_name,
                                              const WorkSpeedProgram& program, double bound_percent) {
  Result<ParsedSpeedProgram> parsed = parse_speed_program(text, file_name);
  if (!parsed) return parsed.error();
  if (Status s = verify_speed_checksum(*parsed, file_name); !s) return s.error();
  Result<SpeedProfileError> e = speed_profile_error(program, parsed->blocks);
  if (!e) return make_error(e.error().code, std::string(file_name) + ": " + e.error().message);
  if (e->max_speed_error_percent > bound_percent) {
    return make_error(ErrorCode::kRefused, std::string(file_name) + ": the control would run C " +
                                               format_fixed(e->max_speed_error_percent, 3) +
                                               " % off the speed program at " + deg_text(e->speed_error_at_c_deg) +
                                               ", above the bound of " + format_fixed(bound_percent, 3) +
                                               " %; write the speed program again");
  }
  return e;
}

}  // namespace gaugeloop

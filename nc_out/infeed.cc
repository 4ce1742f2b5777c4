// The passes from blank to size, and their blocks.
#include "nc_out/infeed.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <sstream>

#include "core/number_text.h"
#include "nc_out/nc_text.h"

namespace gaugeloop {
namespace {

Status out_of_range(std::string_view key, double value, const std::string& allowed) {
  return make_error(ErrorCode::kInvalidInput, "[grinding] " + std::string(key) + " = " + format_fixed(value, 4) +
                                                  " is outside " + allowed + " (docs/parts.md)");
}

// Whole increments of the control's grid in `mm`.
std::int64_t increments(double mm, const CurveTableFormat& format) {
  return std::llround(mm * format.x_increments_per_mm);
}

}  // namespace

int InfeedPlan::turns() const {
  int n = 0;
  for (const InfeedPass& p : passes) n += p.turns;
  return n;
}

Status validate(const GrindingCycle& c) {
  if (!(c.stock_mm >= 0.0 && c.stock_mm <= 5.0)) return out_of_range("stock_mm", c.stock_mm, "[0, 5] mm");
  if (!(c.air_gap_mm >= 0.0 && c.air_gap_mm <= 5.0)) return out_of_range("air_gap_mm", c.air_gap_mm, "[0, 5] mm");
  if (!(c.roughing_infeed_mm_per_turn > 0.0 && c.roughing_infeed_mm_per_turn <= 1.0)) {
    return out_of_range("roughing_infeed_mm_per_turn", c.roughing_infeed_mm_per_turn, "(0, 1] mm");
  }
  if (!(c.finishing_infeed_mm_per_turn > 0.0 && c.finishing_infeed_mm_per_turn <= 1.0)) {
    return out_of_range("finishing_infeed_mm_per_turn", c.finishing_infeed_mm_per_turn, "(0, 1] mm");
  }
  if (!(c.finishing_stock_mm >= 0.0 && c.finishing_stock_mm <= c.stock_mm)) {
    return out_of_range(
        "finishing_stock_mm", c.finishing_stock_mm,
        "[0, stock_mm = " + format_fixed(c.stock_mm, 4) + "] mm: the finishing stock is part of the stock");
  }
  if (c.spark_out_turns < 0 || c.spark_out_turns > 100) {
    return out_of_range("spark_out_turns", c.spark_out_turns, "[0, 100] turns");
  }
  const double rough = c.air_gap_mm + c.stock_mm - c.finishing_stock_mm;
  const double turns = std::ceil(rough / c.roughing_infeed_mm_per_turn - 1e-9) +
                       std::ceil(c.finishing_stock_mm / c.finishing_infeed_mm_per_turn - 1e-9) + c.spark_out_turns;
  if (turns > 1000.0) {
    return make_error(ErrorCode::kInvalidInput, "[grinding] the passes take " + format_fixed(turns, 0) +
                                                    " turns, more than 1000: raise roughing_infeed_mm_per_turn or "
                                                    "finishing_infeed_mm_per_turn, or lower stock_mm (docs/parts.md)");
  }
  return {};
}

Result<InfeedPlan> plan_infeed(const GrindingCycle& c, const CurveTableFormat& format) {
  if (Status s = validate(c); !s) return s.error();
  if (Status s = check_x_resolution(format.x_increments_per_mm, "int_incr_per_mm"); !s) return s.error();
  InfeedPlan plan;
  // In whole increments, so the passes add up to the start offset exactly.
  const std::int64_t finishing = increments(c.finishing_stock_mm, format);
  const std::int64_t start = increments(c.stock_mm + c.air_gap_mm, format);
  const std::int64_t rough = start - finishing;
  auto pass = [&](std::string name, std::int64_t inc, double per_turn_mm) {
    if (inc <= 0) return;
    const double mm = static_cast<double>(inc) / format.x_increments_per_mm;
    const int turns = static_cast<int>(std::ceil(mm / per_turn_mm - 1e-9));
    plan.passes.push_back({std::move(name), std::max(turns, 1), mm});
  };
  pass("roughing", rough, c.roughing_infeed_mm_per_turn);
  pass("finishing", finishing, c.finishing_infeed_mm_per_turn);
  if (c.spark_out_turns > 0) plan.passes.push_back({"spark-out", c.spark_out_turns, 0.0});
  plan.start_offset_mm = static_cast<double>(start) / format.x_increments_per_mm;
  return plan;
}

std::string render_infeed_blocks(const InfeedPlan& plan, double work_speed_rpm, const CurveTableFormat& format) {
  const std::string feed = format_fixed(360.0 * std::abs(work_speed_rpm), 1);
  std::string out = "FGROUP(C)                           ; the feed is C's: F in deg/min";
  for (const InfeedPass& p : plan.passes) {
    std::string block = "G1 G91 C" + format_fixed(360.0 * p.turns, 3);
    if (p.infeed_mm > 0.0) block += " X" + format_fixed(-p.infeed_mm, format.x_decimals());
    block += " F" + feed;
    const std::string what = p.infeed_mm > 0.0
                                 ? p.name + ": " + std::to_string(p.turns) + " turns, " + format_fixed(p.infeed_mm, 4) +
                                       " mm towards the part (" + format_fixed(p.infeed_mm / p.turns, 4) + " a turn)"
                                 : p.name + ": " + std::to_string(p.turns) + " turns at size";
    out += "\n" + block + std::string(block.size() < 36 ? 36 - block.size() : 1, ' ') + "; " + what;
  }
  out += "\nG90\nFGROUP()                            ; the feed back to the geometry axes";
  return out;
}

std::string render_speed_infeed_blocks(const InfeedPlan& plan, std::string_view speed_subprogram) {
  std::string out;
  for (const InfeedPass& p : plan.passes) {
    if (!out.empty()) out += "\n";
    const double per_turn = p.turns > 0 ? p.infeed_mm / p.turns : 0.0;
    const std::string set = std::string(kSpeedInfeedParameter) + "=" + format_fixed(-per_turn, 8);
    out += set + std::string(set.size() < 36 ? 36 - set.size() : 1, ' ') + "; " + p.name + ": " +
           format_fixed(p.infeed_mm, 4) + " mm towards the part over " + std::to_string(p.turns) + " turns";
    const std::string call = std::string(speed_subprogram) + " P" + std::to_string(p.turns);
    out += "\n" + call + std::string(call.size() < 36 ? 36 - call.size() : 1, ' ') + "; " + std::to_string(p.turns) +
           " turns at the programmed work speed";
  }
  out += "\n" + std::string(kSpeedInfeedParameter) + "=0";
  return out;
}

std::string grinding_cycle_text(const CycleOnControl& c) {
  const GrindingCycle& g = c.cycle;
  return "stock_mm " + format_fixed(g.stock_mm, 6) + " air_gap_mm " + format_fixed(g.air_gap_mm, 6) +
         " roughing_infeed_mm_per_turn " + format_fixed(g.roughing_infeed_mm_per_turn, 6) + " finishing_stock_mm " +
         format_fixed(g.finishing_stock_mm, 6) + " finishing_infeed_mm_per_turn " +
         format_fixed(g.finishing_infeed_mm_per_turn, 6) + " spark_out_turns " + std::to_string(g.spark_out_turns) +
         " work_speed_rpm " + format_fixed(c.work_speed_rpm, 3) + " int_incr_per_mm " +
         format_fixed(c.format.x_increments_per_mm, 0);
}

Result<CycleOnControl> read_grinding_cycle_text(std::string_view text) {
  CycleOnControl c;
  std::istringstream in{std::string(text)};
  std::string key;
  std::string value;
  int read = 0;
  while (in >> key) {
    if (!(in >> value)) {
      return make_error(ErrorCode::kInvalidInput, "grinding_cycle: `" + key + "` has no value");
    }
    const std::optional<double> v = nc_text::parse_number(value);
    if (!v) return make_error(ErrorCode::kInvalidInput, "grinding_cycle: `" + key + " " + value + "` is not a number");
    GrindingCycle& g = c.cycle;
    if (key == "stock_mm") {
      g.stock_mm = *v;
    } else if (key == "air_gap_mm") {
      g.air_gap_mm = *v;
    } else if (key == "roughing_infeed_mm_per_turn") {
      g.roughing_infeed_mm_per_turn = *v;
    } else if (key == "finishing_stock_mm") {
      g.finishing_stock_mm = *v;
    } else if (key == "finishing_infeed_mm_per_turn") {
      g.finishing_infeed_mm_per_turn = *v;
    } else if (key == "spark_out_turns") {
      g.spark_out_turns = static_cast<int>(std::lround(*v));
    } else if (key == "work_speed_rpm") {
      c.work_speed_rpm = *v;
    } else if (key == "int_incr_per_mm") {
      c.format.x_increments_per_mm = *v;
    } else {
      return make_error(ErrorCode::kInvalidInput, "grinding_cycle: unknown key `" + key + "`");
    }
    ++read;
  }
  if (read != 8) {
    return make_error(ErrorCode::kInvalidInput,
                      "grinding_cycle: " + std::to_string(read) + " of its 8 values; the header line was cut");
  }
  if (Status s = validate(c.cycle); !s) return s.error();
  return c;
}

}  // namespace gaugeloop

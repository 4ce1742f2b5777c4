// Crankpin programs: the Y table written, rendered from its shipped template and read back as
// the X table is; the main programs that couple X alone (C-X) or X and Y (C-X-Y), and the
// templates refused because they would couple an axis to the other axis' table or leave a
// table undefined.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>

#include "nc_out/main_program.h"
#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"

#include "infeed_values.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

using ::testing::HasSubstr;

using testing::shipped;

// The wheel height of the sample pin ground C-X-Y: Y = R sin C, R = 45 mm, pin angle 0.
SampledPath pin_y_path() {
  constexpr double kThrowMm = 45.0;
  constexpr double k = std::numbers::pi / 180.0;
  SampledPath p;
  p.c_step_deg = 0.01;
  for (int i = 0; i < 36000; ++i) {
    const double t = i * p.c_step_deg * k;
    p.x_mm.push_back(kThrowMm * std::sin(t));
    p.dx_dc_mm_per_deg.push_back(kThrowMm * std::cos(t) * k);
    p.d2x_dc2_mm_per_deg2.push_back(-kThrowMm * std::sin(t) * k * k);
  }
  return p;
}

std::map<std::string, std::string> table_values(const std::string& program) {
  return {{"program_name", program},
          {"part", "crankpin_cxy"},
          {"lobe", "1"},
          {"version", "0.1.0"},
          {"run_id", "42"},
          {"origin", "run 42"},
          {"created_utc", "2026-12-01T10:00:00Z"},
          {"correction_max_um", "3.2"}};
}

TEST(PinYTable, RendersFromTheShippedTemplateAndReadsBackAsAYTable) {
  for (Interpolation interpolation : {Interpolation::kLinear, Interpolation::kCubicSpline}) {
    Result<CurveTable> table = interpolation == Interpolation::kLinear ? write_linear_table(pin_y_path(), 1.0)
                                                                       : write_spline_table(pin_y_path(), 5.0);
    ASSERT_TRUE(table.ok()) << table.error().message;
    Result<std::string> program = render_table_program(shipped("pin_y_table.spf"), "pin_y_table.spf",
                                                       table_values("CRANK_PIN1_XY_Y"), *table, {42, 3, {3, 4}});
    ASSERT_TRUE(program.ok()) << program.error().message;
    EXPECT_THAT(*program, HasSubstr("CTABDEF(Y,C,3,1)"));
    // The spline closes where Y'' = -R sin t vanishes (C180 here), so its top is at C450.
    EXPECT_THAT(*program,
                HasSubstr(interpolation == Interpolation::kLinear ? "C90.000 Y45.0000" : "C450.000 Y45.0000"));

    Result<ParsedTable> back = parse_table_program(*program, "CRANK_PIN1_XY_Y.SPF");
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back->following_axis, "Y");
    EXPECT_EQ(back->leading_axis, "C");
    EXPECT_EQ(back->table_number, 3);
    EXPECT_EQ(back->interpolation, interpolation);
    EXPECT_TRUE(verify_table_checksum(*back, "CRANK_PIN1_XY_Y.SPF").ok());
    EXPECT_TRUE(compare_table_points(*back, table->points, "CRANK_PIN1_XY_Y.SPF").ok());
  }
}

TEST(PinYTable, AHandEditIsReportedUnderTheYAxis) {
  Result<CurveTable> table = write_linear_table(pin_y_path(), 1.0);
  ASSERT_TRUE(table.ok()) << table.error().message;
  Result<std::string> program = render_table_program(shipped("pin_y_table.spf"), "pin_y_table.spf",
                                                     table_values("CRANK_PIN1_XY_Y"), *table, {42, 1, {3, 4}});
  ASSERT_TRUE(program.ok()) << program.error().message;
  std::string edited = *program;
  const size_t at = edited.find("C90.000 Y45.0000");
  ASSERT_NE(at, std::string::npos);
  edited.replace(at, 16, "C90.000 Y45.0010");
  Result<ParsedTable> back = parse_table_program(edited, "CRANK_PIN1_XY_Y.SPF");
  ASSERT_TRUE(back.ok()) << back.error().message;
  Status checksum = verify_table_checksum(*back, "CRANK_PIN1_XY_Y.SPF");
  ASSERT_FALSE(checksum.ok());
  EXPECT_EQ(checksum.error().code, ErrorCode::kRefused);
  Status points = compare_table_points(*back, table->points, "CRANK_PIN1_XY_Y.SPF");
  ASSERT_FALSE(points.ok());
  EXPECT_THAT(points.error().message, HasSubstr("reads C90.000 Y45.0010, the pushed table has C90.000 Y45.0000"));
}

std::map<std::string, std::string> pin_main_values(const std::string& x_number) {
  std::map<std::string, std::string> v{{"program_name", "CRANK_PIN1_XY"},
                                       {"part", "crankpin_cxy"},
                                       {"lobe", "1"},
                                       {"version", "0.1.0"},
                                       {"run_id", "42"},
                                       {"origin", "run 42"},
                                       {"created_utc", "2026-12-01T10:00:00Z"},
                                       {"table_version", "2"},
                                       {"table_number", x_number},
                                       {"table_start_c_deg", "0.000"},
                                       {"point_count", "73"},
                                       {"interpolation", "cspline"}};
  testing::add_infeed_values(v);
  return v;
}

std::map<std::string, std::string> main_values_xy(const std::string& x_number, const std::string& y_number) {
  std::map<std::string, std::string> v = pin_main_values(x_number);
  v["y_program_name"] = pin_y_program_name("CRANK_PIN1_XY");
  v["y_table_number"] = y_number;
  return v;
}

TEST(PinMainProgram, TheCxyTemplateCallsBothTablesAndCouplesEachAxisToItsOwn) {
  Result<std::string> r = render_main_program(shipped("pin_main.mpf"), "pin_main.mpf", main_values_xy("2", "4"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->find("{{"), std::string::npos) << *r;
  EXPECT_THAT(*r, HasSubstr("N10 CRANK_PIN1_XY "));
  EXPECT_THAT(*r, HasSubstr("N15 CRANK_PIN1_XY_Y "));
  EXPECT_THAT(*r, HasSubstr("EGDEF(Y,C,1)"));
  EXPECT_THAT(*r, HasSubstr("EGON(X,\"FINE\",C,2,0)"));
  EXPECT_THAT(*r, HasSubstr("EGON(Y,\"FINE\",C,4,0)"));
  Result<int> coupled = coupled_table_number(*r, "CRANK_PIN1_XY_MAIN.MPF");
  ASSERT_TRUE(coupled.ok()) << coupled.error().message;
  EXPECT_EQ(*coupled, 2);
}

TEST(PinMainProgram, TheCxTemplateRendersAsALobesDoes) {
  Result<std::string> r = render_main_program(shipped("pin_main_cx.mpf"), "pin_main_cx.mpf", pin_main_values("1"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->find("{{"), std::string::npos) << *r;
  EXPECT_THAT(*r, HasSubstr("EGON(X,\"FINE\",C,1,0)"));
  EXPECT_EQ(r->find("EGON(Y"), std::string::npos);
}

TEST(PinMainProgram, YCoupledThroughTheXTableIsRefusedNamingTemplateAndLine) {
  const std::string text =
      "N10 {{program_name}}\nN15 {{y_program_name}}\nN40 EGON(X,\"FINE\",C,{{table_number}},0)\n"
      "N45 EGON(Y,\"FINE\",C,{{table_number}},0)\nM30\n";
  Result<std::string> r = render_main_program(text, "/etc/gaugeloop/pin_main.mpf", main_values_xy("1", "3"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(r.error().message, HasSubstr("/etc/gaugeloop/pin_main.mpf"));
  EXPECT_THAT(r.error().message, HasSubstr("couples Y to curve table 1 at line 4, not table 3"));
  // And the other way round: X through the Y table.
  const std::string swapped =
      "N10 {{program_name}}\nN15 {{y_program_name}}\nN40 EGON(X,\"FINE\",C,{{y_table_number}},0)\n"
      "N45 EGON(Y,\"FINE\",C,{{y_table_number}},0)\nM30\n";
  Result<std::string> s = render_main_program(swapped, "swapped.mpf", main_values_xy("1", "3"));
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message,
              HasSubstr("swapped.mpf: the rendered main program couples X to curve table 3 at line 3"));
}

TEST(PinMainProgram, NotCallingTheYSubprogramIsRefusedNamingTemplateAndTheYCoupling) {
  const std::string text =
      "N10 {{program_name}}\nN40 EGON(X,\"FINE\",C,{{table_number}},0)\n"
      "N45 EGON(Y,\"FINE\",C,{{y_table_number}},0)\nM30\n";
  Result<std::string> r = render_main_program(text, "no_y_call.mpf", main_values_xy("1", "3"));
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("no_y_call.mpf"));
  EXPECT_THAT(r.error().message, HasSubstr("does not call the Y table subprogram CRANK_PIN1_XY_Y"));
  EXPECT_THAT(r.error().message, HasSubstr("couples Y to table 3 at line 3"));
}

TEST(PinMainProgram, AnAxisLeftUncoupledOrOneTableForBothIsRefused) {
  // The lobe's template couples X only: with a Y table it would grind the pin without Y.
  Result<std::string> x_only =
      render_main_program(shipped("pin_main_cx.mpf"), "pin_main_cx.mpf", main_values_xy("1", "3"));
  ASSERT_FALSE(x_only.ok());
  EXPECT_THAT(x_only.error().message, HasSubstr("does not call the Y table subprogram"));
  const std::string text = "N10 {{program_name}}\nN15 {{y_program_name}}\nN40 EGON(X,\"FINE\",C,{{table_number}},0)\n";
  Result<std::string> no_y = render_main_program(text, "no_y.mpf", main_values_xy("1", "3"));
  ASSERT_FALSE(no_y.ok());
  EXPECT_THAT(no_y.error().message, HasSubstr("does not couple Y to curve table 3"));
  Result<std::string> same = render_main_program(shipped("pin_main.mpf"), "pin_main.mpf", main_values_xy("1", "1"));
  ASSERT_FALSE(same.ok());
  EXPECT_THAT(same.error().message, HasSubstr("the same curve table 1"));
  // Two couplings on one block are both read.
  const std::string one_block =
      "N10 {{program_name}}\nN15 {{y_program_name}}\n"
      "N40 EGON(X,\"FINE\",C,{{table_number}},0) EGON(Y,\"FINE\",C,{{table_number}},0)\n";
  Result<std::string> both = render_main_program(one_block, "one_block.mpf", main_values_xy("1", "3"));
  ASSERT_FALSE(both.ok());
  EXPECT_THAT(both.error().message, HasSubstr("couples Y to curve table 1 at line 3"));
}

TEST(PinMainProgram, OnlyOneOfTheYValuesIsRefused) {
  std::map<std::string, std::string> v = pin_main_values("1");
  v["y_table_number"] = "3";
  Result<std::string> r = render_main_program(shipped("pin_main.mpf"), "pin_main.mpf", v);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("needs both y_table_number and y_program_name"));
}

// Every shipped main program feeds the wheel towards the part (X grows as the wheel moves
// away, so the overlaid infeed is negative) and, once the couplings are released, takes the
// wheel off incrementally: an absolute G0 X0 would drive it into the lobe or the pin wherever
// C stopped off the base circle (or away from t = 180 on a pin).
TEST(ShippedMainPrograms, FeedTowardsThePartAndRetractIncrementally) {
  for (const char* name : {"cam_main.mpf", "cam_main_speed.mpf", "pin_main.mpf", "pin_main_cx.mpf"}) {
    const std::string text = shipped(name);
    ASSERT_FALSE(text.empty()) << name;
    std::istringstream lines(text);
    std::string line;
    bool retracts = false;
    while (std::getline(lines, line)) {
      const std::string code = line.substr(0, line.find(';'));
      EXPECT_EQ(code.find("G0 X0"), std::string::npos) << name << ": " << line;
      if (code.find("C3600") != std::string::npos) {
        EXPECT_THAT(code, HasSubstr("X-")) << name << ": " << line;
      }
      if (code.find("G91 G0 X") != std::string::npos) retracts = true;
    }
    EXPECT_TRUE(retracts) << name;
  }
}

}  // namespace
}  // namespace gaugeloop

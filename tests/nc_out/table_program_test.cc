// The rendered program: header, checksum, read-back and hand edits.
#include "nc_out/table_program.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "core/number_text.h"
#include "nc_out/nc_template.h"
#include "tests/nc_out/analytic_path.h"

#include "infeed_values.h"

namespace gaugeloop {
namespace {

using ::testing::HasSubstr;

const std::string kTemplate =
    "; {{program_name}} test "
    "table\n{{table_header}}\nCTABDEF(X,C,{{table_number}},1)\n{{table_blocks}}\nCTABEND\nM17\n";

CurveTable table(Interpolation kind) {
  const SampledPath p = testing::analytic_path(4.0, 0.7);
  Result<CurveTable> t = kind == Interpolation::kLinear ? write_linear_table(p, 2.0) : write_spline_table(p, 4.0);
  EXPECT_TRUE(t.ok());
  return *t;
}

std::string program(const CurveTable& t) {
  Result<std::string> r =
      render_table_program(kTemplate, "CAM.SPF", {{"program_name", "CAM"}, {"table_number", "3"}}, t, {42, 7});
  EXPECT_TRUE(r.ok()) << r.error().message;
  return r.ok() ? *r : "";
}

std::string replace_line(const std::string& text, int line, const std::string& with) {
  size_t pos = 0;
  for (int i = 1; i < line; ++i) pos = text.find('\n', pos) + 1;
  return text.substr(0, pos) + with + text.substr(text.find('\n', pos));
}

// Points come back exactly as written: the writer rounds to the decimals it prints, and
// reading a printed decimal gives the same double back. Tolerance: none.
TEST(TableProgram, RoundTripGivesTheSamePointsAndHeader) {
  for (Interpolation kind : {Interpolation::kLinear, Interpolation::kCubicSpline}) {
    const CurveTable t = table(kind);
    Result<ParsedTable> back = parse_table_program(program(t), "CAM.SPF");
    ASSERT_TRUE(back.ok()) << back.error().message;
    ASSERT_EQ(back->points.size(), t.points.size());
    for (size_t i = 0; i < t.points.size(); ++i) {
      EXPECT_EQ(back->points[i].c_deg, t.points[i].c_deg) << i;
      EXPECT_EQ(back->points[i].x_mm, t.points[i].x_mm) << i;
    }
    EXPECT_EQ(back->interpolation, kind);
    EXPECT_EQ(back->natural_ends, kind == Interpolation::kCubicSpline);
    EXPECT_EQ(back->following_axis, "X");
    EXPECT_EQ(back->leading_axis, "C");
    EXPECT_EQ(back->table_number, 3);
    EXPECT_EQ(back->periodicity, 1);
    EXPECT_EQ(back->ctabdef_line, 12);  // after 1 comment line and 10 header lines
    EXPECT_EQ(back->header.at("seam_c_deg"), format_fixed(t.points.front().c_deg, 3));
    EXPECT_EQ(back->header.at("run_id"), "42");
    EXPECT_EQ(back->header.at("table_version"), "7");
    EXPECT_EQ(back->header.at("interpolation"), interpolation_name(kind));
    EXPECT_EQ(back->header.at("point_count"), std::to_string(t.points.size()));
    EXPECT_EQ(back->header.at("block_count"), std::to_string(t.block_count()));
    char err[32];
    std::snprintf(err, sizeof err, "%.3f", t.error.max_abs_um);
    EXPECT_EQ(back->header.at("command_error_um"), err);
    EXPECT_TRUE(verify_table_checksum(*back, "CAM.SPF").ok());
    EXPECT_TRUE(compare_table_points(*back, t.points, "CAM.SPF").ok());
  }
}

// The spline starts where X bends least (spline_start_c_deg; for this path, X'' = 4 cos C -
// 2.8 sin 2C per rad^2, at C90, where X'' is 0) and runs one turn from there.
TEST(TableProgram, SplineBodyStartsWithG1ThenNaturalCspline) {
  const CurveTable t = table(Interpolation::kCubicSpline);
  const double c0 = spline_start_c_deg(testing::analytic_path(4.0, 0.7));
  EXPECT_EQ(c0, 90.0);
  EXPECT_EQ(t.points.front().c_deg, c0);
  EXPECT_EQ(t.points.back().c_deg, c0 + 360.0);
  const std::string p = program(t);
  EXPECT_THAT(p, HasSubstr("CTABDEF(X,C,3,1)\nG1 C90.000 X"));
  EXPECT_THAT(p, HasSubstr("\nBNAT ENAT CSPLINE C94.000 X"));
  EXPECT_THAT(p, HasSubstr("\nC450.000 X" + format_fixed(t.points.front().x_mm, 4) + "\nCTABEND\nM17\n"));
}

TEST(TableProgram, AHandEditedXIsDetectedWithItsLine) {
  const CurveTable t = table(Interpolation::kLinear);
  const std::string original = program(t);
  Result<ParsedTable> parsed = parse_table_program(original, "CAM.SPF");
  ASSERT_TRUE(parsed.ok());
  const int line = parsed->point_lines[45];  // C90
  const std::string edited = replace_line(original, line, "C90.000 X4.1234");
  Result<ParsedTable> back = parse_table_program(edited, "CAM.SPF");
  ASSERT_TRUE(back.ok()) << back.error().message;
  Status s = verify_table_checksum(*back, "CAM.SPF");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
  EXPECT_THAT(s.error().message, HasSubstr("was edited by hand"));
  EXPECT_THAT(s.error().message, HasSubstr("lines 13..193"));
  // Against the pushed points: the line and both values.
  Status c = compare_table_points(*back, t.points, "CAM.SPF");
  ASSERT_FALSE(c.ok());
  EXPECT_THAT(c.error().message, HasSubstr("CAM.SPF:" + std::to_string(line) + ": point 45 reads C90.000 X4.1234"));
}

TEST(TableProgram, AnEditThatAlsoFixesTheChecksumIsStillCaughtByThePoints) {
  const CurveTable t = table(Interpolation::kLinear);
  std::string edited = program(t);
  Result<ParsedTable> parsed = parse_table_program(edited, "CAM.SPF");
  ASSERT_TRUE(parsed.ok());
  edited = replace_line(edited, parsed->point_lines[10], "C20.000 X0.0000");
  Result<ParsedTable> back = parse_table_program(edited, "CAM.SPF");
  ASSERT_TRUE(back.ok());
  const std::string forged = "; gaugeloop body_checksum_fnv1a64: " + back->body_checksum;
  edited = replace_line(edited, parsed->ctabdef_line - 1, forged);
  back = parse_table_program(edited, "CAM.SPF");
  ASSERT_TRUE(back.ok());
  EXPECT_TRUE(verify_table_checksum(*back, "CAM.SPF").ok());
  EXPECT_FALSE(compare_table_points(*back, t.points, "CAM.SPF").ok());
}

TEST(TableProgram, ACrLfCopyStillVerifies) {
  std::string p = program(table(Interpolation::kLinear));
  std::string crlf;
  for (char ch : p) {
    if (ch == '\n') crlf += '\r';
    crlf += ch;
  }
  Result<ParsedTable> back = parse_table_program(crlf, "CAM.SPF");
  ASSERT_TRUE(back.ok());
  EXPECT_TRUE(verify_table_checksum(*back, "CAM.SPF").ok());
}

TEST(TableProgram, TheChecksumIsFnv1a64) {
  // Published FNV-1a 64 test vectors: "" and "a".
  EXPECT_EQ(table_body_checksum(""), "cbf29ce484222325");
  EXPECT_EQ(table_body_checksum("a"), "af63dc4c8601ec8c");
  EXPECT_EQ(table_body_checksum("a\r"), "af63dc4c8601ec8c");
}

TEST(TableParser, ReadsBlockNumbersCommentsModalXAndEquals) {
  Result<ParsedTable> t = parse_table_program(
      "N5 CTABDEF(Y,X,2,0) ; table\nN10 G1 X0 Y1.5 ; start\nN20 X=10 Y=2\nN30 X20\n; note\nN40 CTABEND\n", "T.SPF");
  ASSERT_TRUE(t.ok()) << t.error().message;
  ASSERT_EQ(t->points.size(), 3u);
  EXPECT_EQ(t->points[1].c_deg, 10.0);
  EXPECT_EQ(t->points[1].x_mm, 2.0);
  EXPECT_EQ(t->points[2].x_mm, 2.0) << "the following axis is modal";
  EXPECT_EQ(t->point_lines[2], 4);
}

TEST(TableParser, NamesTheLineOfWhatItCannotModel) {
  Result<ParsedTable> t = parse_table_program("CTABDEF(X,C,1,1)\nG1 C0 X0\nG2 C10 X1\nCTABEND\n", "CAM.SPF");
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(t.error().message, HasSubstr("CAM.SPF:3: `G2`"));
}

TEST(TableParser, RefusesMixedSegmentsAndAnOpenTable) {
  Result<ParsedTable> mixed =
      parse_table_program("CTABDEF(X,C,1,1)\nG1 C0 X0\nC1 X1\nCSPLINE C2 X0\nCTABEND\n", "CAM.SPF");
  ASSERT_FALSE(mixed.ok());
  EXPECT_THAT(mixed.error().message, HasSubstr("CAM.SPF:4: the table mixes G1 and CSPLINE"));
  Result<ParsedTable> open = parse_table_program("; x\nCTABDEF(X,C,1,1)\nG1 C0 X0\nC1 X1\n", "CAM.SPF");
  ASSERT_FALSE(open.ok());
  EXPECT_THAT(open.error().message, HasSubstr("CAM.SPF:2: CTABDEF is not closed by CTABEND"));
  Result<ParsedTable> back = parse_table_program("CTABDEF(X,C,1,1)\nG1 C0 X0\nC1 X1\nC1 X2\nCTABEND\n", "CAM.SPF");
  ASSERT_FALSE(back.ok());
  EXPECT_THAT(back.error().message, HasSubstr("CAM.SPF:4: C 1.000 does not increase"));
}

// POLY blocks as the manual writes them: the leading axis by its end point, the following by
// its end point with a2 and a3; an axis by its end point alone moves linearly (a2 = a3 = 0).
TEST(TableParser, ReadsPolyBlocksAndRefusesWhatItCannotModel) {
  Result<ParsedTable> t = parse_table_program(
      "CTABDEF(X,C,1,1)\nG1 C0 X0\nPOLY PO[C]=(90.0) PO[X]=(45.0,135.0,-90)\nPO[C]=(180) PO[X]=(0.5)\n"
      "C270 X0.25\nPO[C]=(360) PO[X]=(0,1.5,-2.5) ; last\nCTABEND\n",
      "CAM.SPF");
  ASSERT_TRUE(t.ok()) << t.error().message;
  EXPECT_EQ(t->interpolation, Interpolation::kPoly);
  ASSERT_EQ(t->points.size(), 5u);
  EXPECT_EQ(t->points[1].c_deg, 90.0);
  EXPECT_EQ(t->points[1].x_mm, 45.0);
  EXPECT_EQ(t->points[1].a2_mm, 135.0);
  EXPECT_EQ(t->points[1].a3_mm, -90.0);
  EXPECT_EQ(t->points[2].a2_mm, 0.0) << "an end point alone: a linear segment";
  EXPECT_EQ(t->points[3].x_mm, 0.25);
  EXPECT_EQ(t->points[4].a3_mm, -2.5);
  // The manual's segment (0 -> 45 over 90 deg, a2 135, a3 -90: a1 = 0) read as the NC reads it:
  // X(p) = 135 p^2 - 90 p^3, at C45 (p = 0.5) 33.75 - 11.25 = 22.5, slope 0 at both ends.
  Result<TableInterpolant> nc = TableInterpolant::of(t->points, t->interpolation);
  ASSERT_TRUE(nc.ok()) << nc.error().message;
  EXPECT_NEAR(nc->at(45.0).x_mm, 22.5, 1e-12);
  EXPECT_NEAR(nc->at(0.0).dx_dc_mm_per_deg, 0.0, 1e-12);
  EXPECT_NEAR(nc->at(90.0 - 1e-9).dx_dc_mm_per_deg, 0.0, 1e-6);
  EXPECT_NEAR(nc->at(135.0).x_mm, 45.0 + 0.5 * (0.5 - 45.0), 1e-12) << "the linear segment";

  for (const auto& [body, why] : std::vector<std::pair<std::string, std::string>>{
           {"G1 C0 X0\nPOLY PO[C]=(90) PO[X]=(1,2,3) PL=2\n", "`PL=2`"},
           {"G1 C0 X0\nC90 PO[X]=(1,2,3)\n", "polynomial coefficients outside POLY"},
           {"G1 C0 X0\nPOLY PO[C]=(90,1) PO[X]=(1)\n", "by its end point alone"},
           {"G1 C0 X0\nPOLY PO[C]=(90) PO[Z]=(1)\n", "neither the leading axis C nor the following axis X"},
           {"G1 C0 X0\nPOLY PO[C]=(90) PO[X]=(1,2,3,4)\n", "the end point, a2 and a3 at most"},
           {"G1 C0 X0\nPOLY PO[C]=(90) PO[X]=(1,x)\n", "not a number"},
           {"G1 C0 X0\nPOLY PO[C]=(90) PO[X]=(1)\nG1 C180 X0\n", "the table mixes POLY and G1"},
       }) {
    Result<ParsedTable> bad = parse_table_program("CTABDEF(X,C,1,1)\n" + body + "CTABEND\n", "CAM.SPF");
    ASSERT_FALSE(bad.ok()) << body;
    EXPECT_THAT(bad.error().message, HasSubstr(why)) << body;
    EXPECT_THAT(bad.error().message, HasSubstr("CAM.SPF:")) << "names the line";
  }
}

// A POLY table written, rendered and read back: the same points and coefficients, and a hand
// edit of one coefficient is caught by the points (even with the checksum fixed).
TEST(TableProgram, APolyTableRoundTripsAndAnEditedCoefficientIsCaught) {
  const SampledPath p = testing::analytic_path(4.0, 0.7);
  Result<CurveTable> t = write_poly_table(p, 5.0);
  ASSERT_TRUE(t.ok()) << t.error().message;
  const std::string text = program(*t);
  Result<ParsedTable> back = parse_table_program(text, "CAM.SPF");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->interpolation, Interpolation::kPoly);
  EXPECT_EQ(back->header.at("interpolation"), "poly");
  EXPECT_TRUE(compare_table_points(*back, t->points, "CAM.SPF").ok());
  EXPECT_TRUE(verify_table_checksum(*back, "CAM.SPF").ok());
  ParsedTable edited = *back;
  edited.points[3].a2_mm += 0.001;
  Status s = compare_table_points(edited, t->points, "CAM.SPF");
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("a2,a3 read"));
}

TEST(TableProgram, RefusesATemplateThatPutsTextInsideTheTable) {
  const std::string bad = "{{table_header}}\nCTABDEF(X,C,1,1)\nG1 C0 X0\n{{table_blocks}}\nCTABEND\n";
  Result<std::string> r = render_table_program(bad, "bad.spf", {}, table(Interpolation::kLinear), {1, 1});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(r.error().message, HasSubstr("bad.spf: the rendered program does not read back"));
}

TEST(TableProgram, RefusesATemplateWithoutTheHeader) {
  const std::string bad = "CTABDEF(X,C,1,1)\n{{table_blocks}}\nCTABEND\n";
  Result<std::string> r = render_table_program(bad, "bad.spf", {}, table(Interpolation::kLinear), {1, 1});
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("body_checksum_fnv1a64"));
}

TEST(TableProgram, TheExampleTemplatesRenderWithTheDocumentedPlaceholders) {
  std::map<std::string, std::string> values = {{"program_name", "CAM_INTAKE_L1"},
                                               {"part", "intake_flat"},
                                               {"lobe", "1"},
                                               {"version", "0.1.0"},
                                               {"run_id", "42"},
                                               {"origin", "run 42"},
                                               {"created_utc", "2024-05-01T10:00:00Z"},
                                               {"correction_max_um", "3.2"},
                                               {"table_number", "1"}};
  for (const char* file : {"cam_table.spf", "cam_main.mpf"}) {
    std::ifstream in(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/sinumerik/" + file);
    std::stringstream ss;
    ss << in.rdbuf();
    ASSERT_FALSE(ss.str().empty()) << file;
    if (std::string(file) == "cam_table.spf") {
      Result<std::string> r = render_table_program(ss.str(), file, values, table(Interpolation::kCubicSpline), {42, 7});
      ASSERT_TRUE(r.ok()) << r.error().message;
    } else {
      std::map<std::string, std::string> main_values = values;
      main_values["point_count"] = "91";
      main_values["interpolation"] = "cspline";
      main_values["table_version"] = "7";
      main_values["table_start_c_deg"] = "180.000";
      testing::add_infeed_values(main_values);
      Result<std::string> r = render_nc_template(ss.str(), file, main_values);
      ASSERT_TRUE(r.ok()) << r.error().message;
      EXPECT_THAT(*r, HasSubstr("N10 CAM_INTAKE_L1 "));
      EXPECT_THAT(*r, HasSubstr("EGON(X,\"FINE\",C,1,0)"));
      EXPECT_THAT(*r, HasSubstr("G0 C180.000 "));
    }
  }
}

}  // namespace
}  // namespace gaugeloop

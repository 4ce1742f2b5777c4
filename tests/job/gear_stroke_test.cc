// The gear's stroke program written from the example axis errors, read back by the test's own
// reader and checked against dSIM re-derived from the per-axis errors with the coupling factors
// of the independent generating model (tests/compensation/generating_model.h); pushed with its
// versions, main program and rollback; and the refusals that leave nothing written.
#include "job/gear_stroke.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "cli/embedded_defaults.h"
#include "config/gear_file.h"
#include "storage/run_store.h"
#include "tests/compensation/generating_model.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
const fs::path kExamples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";

using testing::slurp;

// The example's rows, read here apart from the product's reader: z, eY um, eZ um, eB deg, eC deg.
std::vector<std::array<double, 5>> csv_rows(const fs::path& p) {
  std::vector<std::array<double, 5>> rows;
  std::istringstream in(slurp(p));
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      EXPECT_EQ(line, "z_mm,y_error_um,z_error_um,b_error_deg,c_error_deg") << "the test reads this column order";
      header = false;
      continue;
    }
    std::array<double, 5> r{};
    std::istringstream cells(line);
    std::string cell;
    for (double& v : r) {
      std::getline(cells, cell, ',');
      v = std::stod(cell);
    }
    rows.push_back(r);
  }
  return rows;
}

// Every `Z.. SIM1=..` block of `text` (a stroke program), read by the test's own pattern.
std::vector<std::pair<double, double>> stroke_points(const std::string& text) {
  const std::regex block(R"(Z(-?[0-9]+\.[0-9]+) SIM1=(-?[0-9]+\.[0-9]+))");
  std::vector<std::pair<double, double>> points;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), block); it != std::sregex_iterator(); ++it) {
    points.emplace_back(std::stod((*it)[1]), std::stod((*it)[2]));
  }
  return points;
}

// The stroke program `text` holds, at every spline point, dSIM re-derived from the axis errors of
// `csv` with the factors of the independent generating model.
void expect_dsim_of_the_axis_errors(const std::string& text, const GearPartFile& gf, const fs::path& csv) {
  const std::vector<std::pair<double, double>> points = stroke_points(text);
  ASSERT_EQ(points.size(), 31u) << "Z -15 to 15 every 1 mm";
  EXPECT_EQ(points.front().first, -15.0);
  EXPECT_EQ(points.back().first, 15.0);

  const testing::GeneratingModel model(gf.part);
  const testing::NumericFactors k = testing::numeric_factors(model);
  const auto rows = csv_rows(csv);
  double largest = 0.0;
  for (const auto& [z, sim] : points) {
    std::size_t i = 0;
    while (i + 2 < rows.size() && rows[i + 1][0] < z) ++i;
    const double t = (z - rows[i][0]) / (rows[i + 1][0] - rows[i][0]);
    auto at = [&](int col) { return rows[i][col] + t * (rows[i + 1][col] - rows[i][col]); };
    // Where the axes stand less where they were commanded moves the mesh by the model's factors;
    // C's own error is taken back.
    const double expected = k.s_yc * at(1) / 1000.0 + k.s_zc * at(2) / 1000.0 + k.s_bc * at(3) - at(4);
    // Half of SIM1's increment (1e-6 deg) and the model's agreement with the closed forms.
    EXPECT_NEAR(sim, expected, 0.5e-6 + 1e-9) << "Z " << z;
    largest = std::max(largest, std::abs(expected));
  }
  EXPECT_GT(largest, 0.003) << "the example's errors move SIM1 by a few thousandths of a degree";
}

// The example gear's stroke settings, written into `dir`.
GearStrokeSettings settings_for(const GearPartFile& gf, const testing::TempDir& dir) {
  GearStrokeSettings s;
  s.part_name = gf.name;
  s.program_name = gf.nc_program;
  s.out_file = dir.path() / "GEAR_71_STROKE.SPF";
  return s;
}

TEST(GearStroke, TheProgramHoldsDsimReDerivedFromThePerAxisErrors) {
  Result<GearPartFile> gf = read_gear_part_file(kExamples / "gear_71.toml");
  ASSERT_TRUE(gf.ok()) << gf.error().message;
  Result<StrokeAxisErrors> errors = read_axis_errors_csv(kExamples / "gear_71_axis_errors.csv");
  ASSERT_TRUE(errors.ok()) << errors.error().message;
  testing::TempDir dir("gear-stroke");
  GearStrokeSettings s = settings_for(*gf, dir);
  s.format.sim_increments_per_deg = 1e6;
  Result<GearStrokeReport> r = write_gear_stroke(gf->part, *errors, s);
  ASSERT_TRUE(r.ok()) << r.error().message;

  const std::string text = slurp(s.out_file);
  expect_dsim_of_the_axis_errors(text, *gf, kExamples / "gear_71_axis_errors.csv");
  EXPECT_NE(text.find("; gaugeloop body_checksum_fnv1a64: "), std::string::npos);
  EXPECT_NE(r->coupling_lines.find("EGON(C,\"FINE\",B,-1,71,Z,"), std::string::npos) << r->coupling_lines;
}

TEST(GearStroke, ErrorsThatDoNotCoverTheStrokeOrABadPartWriteNothing) {
  Result<GearPartFile> gf = read_gear_part_file(kExamples / "gear_71.toml");
  ASSERT_TRUE(gf.ok()) << gf.error().message;
  testing::TempDir dir("gear-stroke-bad");
  const GearStrokeSettings s = settings_for(*gf, dir);
  Result<StrokeAxisErrors> short_errors = parse_axis_errors_csv(
      "z_mm,y_error_um,z_error_um,b_error_deg,c_error_deg\n-10,1,1,0,0\n10,1,1,0,0\n", "short.csv");
  ASSERT_TRUE(short_errors.ok()) << short_errors.error().message;
  Result<GearStrokeReport> r = write_gear_stroke(gf->part, *short_errors, s);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(r.error().message.find("short.csv: the errors are known from Z -10.000 to 10.000 mm"), std::string::npos)
      << r.error().message;
  EXPECT_FALSE(fs::exists(s.out_file));

  GearPart bad = gf->part;
  bad.worm.starts = 0;
  Result<StrokeAxisErrors> errors = read_axis_errors_csv(kExamples / "gear_71_axis_errors.csv");
  ASSERT_TRUE(errors.ok());
  Result<GearStrokeReport> b = write_gear_stroke(bad, *errors, s);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find("[gear.worm] starts"), std::string::npos) << b.error().message;
  EXPECT_FALSE(fs::exists(s.out_file));
}

// The example's axis errors doubled, written to `path` in the example's columns.
fs::path doubled_errors(const fs::path& path) {
  std::ofstream out(path);
  out << "z_mm,y_error_um,z_error_um,b_error_deg,c_error_deg\n";
  for (const auto& r : csv_rows(kExamples / "gear_71_axis_errors.csv")) {
    out << r[0] << ',' << 2 * r[1] << ',' << 2 * r[2] << ',' << 2 * r[3] << ',' << 2 * r[4] << '\n';
  }
  return path;
}

// Settings that push into dir/nc with the history in `store` and the built-in gear main program.
GearStrokeSettings push_settings(const GearPartFile& gf, const testing::TempDir& dir, RunStore& store) {
  GearStrokeSettings s;
  s.part_name = gf.name;
  s.program_name = gf.nc_program;
  s.format.sim_increments_per_deg = 1e6;
  s.store = &store;
  s.nc_file = dir.path() / "nc" / (gf.nc_program + ".SPF");
  fs::create_directories(s.nc_file.parent_path());
  s.main.gear_template_text = std::string(embedded::kGearMainTemplate);
  s.main.gear_template_name = "gear_main.mpf";
  return s;
}

TEST(GearStroke, PushedWithItsVersionsAMainProgramCouplingSim1AndARollback) {
  Result<GearPartFile> gf = read_gear_part_file(kExamples / "gear_71.toml");
  ASSERT_TRUE(gf.ok()) << gf.error().message;
  testing::TempDir dir("gear-stroke-push");
  Result<RunStore> store = RunStore::open(dir.path() / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok()) << store.error().message;
  GearStrokeSettings s = push_settings(*gf, dir, *store);
  const fs::path example = kExamples / "gear_71_axis_errors.csv";
  const fs::path doubled = doubled_errors(dir.path() / "doubled.csv");

  Result<StrokeAxisErrors> errors = read_axis_errors_csv(example);
  ASSERT_TRUE(errors.ok()) << errors.error().message;
  Result<GearStrokeReport> v1 = write_gear_stroke(gf->part, *errors, s);
  ASSERT_TRUE(v1.ok()) << v1.error().message;
  EXPECT_EQ(v1->version, 1);
  const std::string text1 = slurp(s.nc_file);
  expect_dsim_of_the_axis_errors(text1, *gf, example);
  EXPECT_NE(text1.find("; gaugeloop table_version: 1\n"), std::string::npos) << text1;

  // The main program: the gearbox with the part's factors (the model's, to 1e-9), then the stroke.
  const std::string main1 = slurp(dir.path() / "nc" / "GEAR_71_MAIN.MPF");
  const std::regex egon(R"(\nEGON\(C,"FINE",B,(-?[0-9]+),([0-9]+),Z,(-?[0-9.]+),1,Y,(-?[0-9.]+),1,SIM1,1,1\)\n)");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(main1, m, egon)) << main1;
  const testing::NumericFactors k = testing::numeric_factors(testing::GeneratingModel(gf->part));
  EXPECT_NEAR(std::stod(m[1]) / std::stod(m[2]), k.s_bc, 1e-9);
  EXPECT_NEAR(std::stod(m[3]), k.s_zc, 1e-9 * std::abs(k.s_zc));
  EXPECT_NEAR(std::stod(m[4]), k.s_yc, 1e-9 * std::abs(k.s_yc));
  const std::size_t egdef = main1.find("\nEGDEF(C,B,1,Z,1,Y,1,SIM1,1)\n");
  const std::size_t call = main1.find("\nN40 GEAR_71 ");
  ASSERT_NE(egdef, std::string::npos) << main1;
  ASSERT_NE(call, std::string::npos) << main1;
  EXPECT_LT(egdef, call) << "coupled before the stroke runs";
  EXPECT_NE(main1.find("with stroke version 1 "), std::string::npos) << main1;

  Result<StrokeAxisErrors> twice = read_axis_errors_csv(doubled);
  ASSERT_TRUE(twice.ok()) << twice.error().message;
  Result<GearStrokeReport> v2 = write_gear_stroke(gf->part, *twice, s);
  ASSERT_TRUE(v2.ok()) << v2.error().message;
  EXPECT_EQ(v2->version, 2);
  const std::string text2 = slurp(s.nc_file);
  expect_dsim_of_the_axis_errors(text2, *gf, doubled);
  Result<std::optional<NcPush>> last = store->last_push(s.nc_file.string());
  ASSERT_TRUE(last.ok() && last->has_value());
  EXPECT_EQ((**last).table_version, 2);
  EXPECT_EQ((**last).reason, "stroke from " + doubled.string());
  EXPECT_EQ((**last).table.point_count, 31);

  // Back to version 1: its points again, as version 3, and the main program rewritten for it.
  Result<PushOutcome> back = rollback_to_version(*store, s.nc_file.string(), 1, "anna", s.main);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->table_version, 3);
  EXPECT_TRUE(back->stroke);
  const std::string text3 = slurp(s.nc_file);
  EXPECT_EQ(stroke_points(text3), stroke_points(text1));
  EXPECT_NE(text3.find("; gaugeloop table_version: 3\n"), std::string::npos) << text3;
  EXPECT_NE(slurp(dir.path() / "nc" / "GEAR_71_MAIN.MPF").find("with stroke version 3 "), std::string::npos);
}

TEST(GearStroke, AHandEditOrAnotherVersionCopiedInIsNotOverwritten) {
  Result<GearPartFile> gf = read_gear_part_file(kExamples / "gear_71.toml");
  ASSERT_TRUE(gf.ok()) << gf.error().message;
  testing::TempDir dir("gear-stroke-edit");
  Result<RunStore> store = RunStore::open(dir.path() / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok()) << store.error().message;
  GearStrokeSettings s = push_settings(*gf, dir, *store);
  Result<StrokeAxisErrors> errors = read_axis_errors_csv(kExamples / "gear_71_axis_errors.csv");
  ASSERT_TRUE(errors.ok());
  ASSERT_TRUE(write_gear_stroke(gf->part, *errors, s).ok());
  const std::string v1 = slurp(s.nc_file);
  ASSERT_TRUE(write_gear_stroke(gf->part, *errors, s).ok());
  const std::string v2 = slurp(s.nc_file);

  // One SIM1 value changed on the control.
  std::string edited = v2;
  const std::size_t at = edited.find("SIM1=", edited.find("FGROUP(Z)"));
  edited.replace(at, 6, "SIM1=9");
  std::ofstream(s.nc_file, std::ios::binary) << edited;
  Result<GearStrokeReport> r = write_gear_stroke(gf->part, *errors, s);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kRefused);
  EXPECT_NE(r.error().message.find("was edited by hand since version 2"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("gear stroke --overwrite-edited"), std::string::npos) << r.error().message;
  EXPECT_EQ(slurp(s.nc_file), edited) << "the hand edit stays";

  // Version 1 copied back by hand: a stroke gaugeloop wrote, but not the one last pushed.
  std::ofstream(s.nc_file, std::ios::binary) << v1;
  Result<GearStrokeReport> c = write_gear_stroke(gf->part, *errors, s);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("is not the stroke program last pushed"), std::string::npos) << c.error().message;
  EXPECT_NE(c.error().message.find("table_version 1, the push recorded 2"), std::string::npos) << c.error().message;

  s.overwrite_edited = true;
  Result<GearStrokeReport> o = write_gear_stroke(gf->part, *errors, s);
  ASSERT_TRUE(o.ok()) << o.error().message;
  EXPECT_EQ(o->version, 3);
}

TEST(GearStroke, AMainTemplateWithoutTheGearboxIsRefusedBeforeAnythingIsWritten) {
  Result<GearPartFile> gf = read_gear_part_file(kExamples / "gear_71.toml");
  ASSERT_TRUE(gf.ok()) << gf.error().message;
  Result<StrokeAxisErrors> errors = read_axis_errors_csv(kExamples / "gear_71_axis_errors.csv");
  ASSERT_TRUE(errors.ok());
  const std::string gearbox = "{{gearbox_coupling}}\n";
  const std::string call = "N40 {{program_name}}\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"N10 SIM1=0\nM30\n", "does not couple C to B, Z, Y and SIM1 (no {{gearbox_coupling}})"},
      {"N10 SIM1=0\n" + call + gearbox + "M30\n", "calls the stroke subprogram GEAR_71 at line 2 before C is coupled"},
      {gearbox + "EGON(C,\"FINE\",B,1,71)\n" + call + "M30\n", "makes a coupling of its own at line 3"},
      {gearbox + call + "EGDEF(X,C,1)\nM30\n", "makes a coupling of its own at line 4 (`EGDEF(X,C,1)`)"},
      // The cam's main program: its placeholders are a lobe's.
      {std::string(embedded::kNcMainTemplate), "unknown placeholder {{lobe}}"},
      {gearbox + "M30\n", "does not call the stroke subprogram GEAR_71"},
  };
  for (const auto& [text, why] : cases) {
    testing::TempDir dir("gear-stroke-main");
    Result<RunStore> store = RunStore::open(dir.path() / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    GearStrokeSettings s = push_settings(*gf, dir, *store);
    s.main.gear_template_text = text;
    Result<GearStrokeReport> r = write_gear_stroke(gf->part, *errors, s);
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(r.error().message.find(why), std::string::npos) << r.error().message;
    EXPECT_TRUE(fs::is_empty(dir.path() / "nc")) << "nothing on the control: " << text;
    Result<std::optional<NcPush>> last = store->last_push(s.nc_file.string());
    ASSERT_TRUE(last.ok());
    EXPECT_FALSE(last->has_value());
    Result<std::vector<PushIntent>> open = store->open_push_intents();
    ASSERT_TRUE(open.ok());
    EXPECT_TRUE(open->empty()) << "nothing in the journal";
  }
}

TEST(GearStroke, TheErrorTableNamesTheLineAndColumnOfWhatIsWrong) {
  const std::string head = "z_mm,y_error_um,z_error_um,b_error_deg,c_error_deg\n";
  Result<StrokeAxisErrors> bad_value = parse_axis_errors_csv(head + "0,1,1,0,0\n1,1,x,0,0\n", "e.csv");
  ASSERT_FALSE(bad_value.ok());
  EXPECT_NE(bad_value.error().message.find("e.csv:3: column z_error_um: `x` is not a number"), std::string::npos)
      << bad_value.error().message;
  Result<StrokeAxisErrors> unknown = parse_axis_errors_csv("z_mm,x_error_um\n", "e.csv");
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.error().message.find("e.csv:1: unknown column `x_error_um`"), std::string::npos);
  Result<StrokeAxisErrors> short_row = parse_axis_errors_csv(head + "0,1,1\n", "e.csv");
  ASSERT_FALSE(short_row.ok());
  EXPECT_NE(short_row.error().message.find("e.csv:2: 3 values"), std::string::npos);
  Result<StrokeAxisErrors> reordered =
      parse_axis_errors_csv("c_error_deg,b_error_deg,z_error_um,y_error_um,z_mm\n0.1,0.2,3,4,-5\n", "e.csv");
  ASSERT_TRUE(reordered.ok()) << reordered.error().message;
  EXPECT_EQ(reordered->z_mm.front(), -5.0);
  EXPECT_EQ(reordered->c_error_deg.front(), 0.1);
}

}  // namespace
}  // namespace gaugeloop

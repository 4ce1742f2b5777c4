// The gear's stroke program written from the example axis errors, read back by the test's own
// reader and checked against dSIM re-derived from the per-axis errors with the coupling factors
// of the independent generating model (tests/compensation/generating_model.h); and the refusals
// that leave nothing written.
#include "job/gear_stroke.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "config/gear_file.h"
#include "tests/compensation/generating_model.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
const fs::path kExamples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The example's rows, read here apart from the product's reader: z, eY um, eZ um, eB deg, eC deg.
std::vector<std::array<double, 5>> csv_rows(const fs::path& p) {
  std::vector<std::array<double, 5>> rows;
  std::istringstream in(read_text(p));
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

  // The program as text: every `Z.. SIM1=..` block.
  const std::string text = read_text(s.out_file);
  const std::regex block(R"(Z(-?[0-9]+\.[0-9]+) SIM1=(-?[0-9]+\.[0-9]+))");
  std::vector<std::pair<double, double>> points;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), block); it != std::sregex_iterator(); ++it) {
    points.emplace_back(std::stod((*it)[1]), std::stod((*it)[2]));
  }
  ASSERT_EQ(points.size(), 31u) << "Z -15 to 15 every 1 mm";
  EXPECT_EQ(points.front().first, -15.0);
  EXPECT_EQ(points.back().first, 15.0);

  const testing::GeneratingModel model(gf->part);
  const testing::NumericFactors k = testing::numeric_factors(model);
  const auto rows = csv_rows(kExamples / "gear_71_axis_errors.csv");
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

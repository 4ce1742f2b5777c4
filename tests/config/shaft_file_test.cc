// Shaft files: the layout read back, the part files read for their names and lobe numbers,
// and every refusal naming the file, line and key.
#include "config/shaft_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/refused.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

using testing::refused;
namespace fs = std::filesystem;

std::string part_text(const std::string& name, int lobe, double c_offset_deg) {
  return "name = \"" + name + "\"\nlobe = " + std::to_string(lobe) +
         "\nlift_table = \"x.csv\"\nfollower = \"flat\"\nbase_circle_radius_mm = 18\nwheel_radius_mm = 200\n"
         "c_offset_deg = " +
         std::to_string(c_offset_deg) + "\nnc_program = \"P\"\n";
}

class ShaftFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    write("intake.toml", part_text("intake", 1, 30.0));
    write("exhaust.toml", part_text("exhaust", 2, 140.0));
    write("intake_again.toml", part_text("intake_b", 1, 30.0));
  }
  void write(const std::string& name, const std::string& text) { std::ofstream(dir_.path() / name) << text; }
  Result<ShaftFile> parse(const std::string& text) { return parse_shaft_toml(text, "shaft.toml", dir_.path()); }

  testing::TempDir dir_;
};

const std::string kTwoLobes =
    "name = \"S\"\n"
    "reference_c_deg = 30\n"
    "index_tolerance_deg = 0.25\n"
    "[[lobe]]\n"
    "part = \"intake.toml\"\n"
    "angle_deg = 0\n"
    "[[lobe]]\n"
    "part = \"exhaust.toml\"\n"
    "angle_deg = 110.0\n";

TEST_F(ShaftFileTest, ReadsEveryKeyAndThePartNamesAndLobes) {
  auto s = parse(kTwoLobes);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->layout.name, "S");
  EXPECT_EQ(s->layout.reference_c_deg, 30.0);
  EXPECT_EQ(s->layout.index_tolerance_deg, 0.25);
  ASSERT_EQ(s->layout.lobes.size(), 2u);
  EXPECT_EQ(s->layout.lobes[0].part, "intake");
  EXPECT_EQ(s->layout.lobes[0].lobe, 1);
  EXPECT_EQ(s->layout.lobes[0].angle_deg, 0.0);
  EXPECT_EQ(s->layout.lobes[1].part, "exhaust");
  EXPECT_EQ(s->layout.lobes[1].lobe, 2);
  EXPECT_EQ(s->layout.lobes[1].angle_deg, 110.0);
  EXPECT_EQ(s->layout.lobes[1].part_file, dir_.path() / "exhaust.toml");
  EXPECT_TRUE(s->notes.empty()) << s->notes.front();  // both part files grind where the shaft wants
}

TEST_F(ShaftFileTest, DefaultsWithoutReferenceOrTolerance) {
  auto s = parse("name = \"S\"\n[[lobe]]\npart = \"intake.toml\"\nangle_deg = 30\n");
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->layout.reference_c_deg, 0.0);
  EXPECT_FALSE(s->layout.index_tolerance_deg.has_value());
}

TEST_F(ShaftFileTest, APartFileGrindingElsewhereIsNoted) {
  auto s = parse("name = \"S\"\n[[lobe]]\npart = \"exhaust.toml\"\nangle_deg = 100\n");
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(s->notes.size(), 1u);
  EXPECT_NE(s->notes[0].find("C = 140.000 deg, the shaft places it at C = 100.000 deg"), std::string::npos)
      << s->notes[0];
  EXPECT_NE(s->notes[0].find("+40.000"), std::string::npos) << s->notes[0];
}

TEST_F(ShaftFileTest, Refusals) {
  EXPECT_TRUE(
      refused(parse(kTwoLobes + "speed = 1\n"), "shaft.toml:10: key `lobe.speed`"));  // after [[lobe]], the lobe's key
  EXPECT_TRUE(refused(parse("name = \"S\"\nreference = 3\n[[lobe]]\npart = \"intake.toml\"\nangle_deg = 0\n"),
                      "shaft.toml:2: key `reference`"));
  EXPECT_TRUE(refused(parse("name = \"S\"\n"), "shaft.toml: no [[lobe]] entries"));
  EXPECT_TRUE(refused(parse("reference_c_deg = 0\n[[lobe]]\npart = \"intake.toml\"\nangle_deg = 0\n"), "`name`"));
  EXPECT_TRUE(refused(parse("name = \"S\"\nindex_tolerance_deg = 0\n[[lobe]]\npart = \"intake.toml\"\nangle_deg = 0\n"),
                      "shaft.toml:2: key `index_tolerance_deg`: 0 is out of range; allowed (0, 180]"));
  EXPECT_TRUE(refused(parse("name = \"S\"\n[[lobe]]\npart = \"intake.toml\"\nangle_deg = 400\n"),
                      "shaft.toml:4: key `lobe.angle_deg`: 400 is out of range"));
  EXPECT_TRUE(refused(parse("name = \"S\"\n[[lobe]]\npart = \"intake.toml\"\n"), "`lobe.angle_deg`"));
  EXPECT_TRUE(refused(parse("name = \"S\"\n[[lobe]]\npart = \"intake.toml\"\nangle_deg = 0\nphase = 1\n"),
                      "shaft.toml:5: key `lobe.phase`: unknown key"));
  // The same lobe number twice, from two part files.
  EXPECT_TRUE(refused(parse("name = \"S\"\n[[lobe]]\npart = \"intake.toml\"\nangle_deg = 0\n"
                            "[[lobe]]\npart = \"intake_again.toml\"\nangle_deg = 90\n"),
                      "shaft.toml:6: key `lobe.part`: lobe 1 (part intake_b) is on the shaft twice"));
  // A part file that is not there: its own error, with where the shaft names it.
  EXPECT_TRUE(refused(parse("name = \"S\"\n[[lobe]]\npart = \"nothing.toml\"\nangle_deg = 0\n"), ErrorCode::kNotFound,
                      "shaft.toml:3: key `lobe.part`: "));
}

TEST(ShaftFile, TheSampleCamshaftReads) {
  auto s = read_shaft_file(fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / "camshaft.toml");
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(s->layout.lobes.size(), 2u);
  EXPECT_EQ(s->layout.lobes[0].part, "intake_flat");
  EXPECT_EQ(s->layout.lobes[0].lobe, 1);
  EXPECT_EQ(s->layout.lobes[1].part, "exhaust_roller");
  EXPECT_EQ(s->layout.lobes[1].lobe, 2);
  EXPECT_EQ(s->layout.lobes[1].angle_deg, 110.0);
  EXPECT_EQ(s->layout.index_tolerance_deg, 0.25);
}

TEST(ShaftFile, AMissingFileIsNotFound) {
  EXPECT_TRUE(refused(read_shaft_file("/nonexistent/shaft.toml"), ErrorCode::kNotFound, "/nonexistent/shaft.toml"));
}

}  // namespace
}  // namespace gaugeloop

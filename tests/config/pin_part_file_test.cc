// Crankpin part files: a [pin] section read back in both modes, the sample pins in examples/,
// and every refusal naming the file, line and key.
#include <gtest/gtest.h>

#include <string>
#include <tuple>
#include <utility>

#include "config/part_file.h"
#include "tests/support/refused.h"

namespace gaugeloop {
namespace {

using testing::refused;

// A complete pin ground in `mode`; `extra_top` goes after the top-level keys (line 4 on),
// `extra_pin` after [pin.tolerance] (line 15 on).
std::string pin_part(const std::string& mode = "c-x", const std::string& extra_top = {},
                     const std::string& extra_pin = {}) {
  return "name = \"crank\"\n"
         "pin_number = 3\n"
         "nc_program = \"CRANK_PIN3\"\n" +
         extra_top +
         "[pin]\n"
         "throw_mm = 45.0\n"
         "pin_radius_mm = 25.0\n"
         "wheel_radius_mm = 300.0\n"
         "pin_angle_deg = 240.0\n"
         "mode = \"" +
         mode +
         "\"\n"
         "[pin.tolerance]\n"
         "roundness_um = 4.0\n"
         "diameter_error_um = [-5.0, 8.0]\n"
         "stroke_error_um = 25.0\n"
         "index_error_deg = 0.03\n" +
         extra_pin;
}

Result<PartFile> parse_pin(const std::string& text) { return parse_part_toml(text, "pin.toml", "/parts"); }

TEST(PinPartFile, ReadsEveryKeyInBothModes) {
  for (const auto& [name, mode] : {std::pair{"c-x", PinMode::kCX}, std::pair{"c-x-y", PinMode::kCXY}}) {
    Result<PartFile> pf = parse_pin(pin_part(name));
    ASSERT_TRUE(pf.ok()) << pf.error().message;
    ASSERT_TRUE(pf->pin.has_value());
    const PinGeometry& pin = *pf->pin;
    EXPECT_EQ(pin.mode, mode);
    EXPECT_EQ(pin.throw_mm, 45.0);
    EXPECT_EQ(pin.pin_radius_mm, 25.0);
    EXPECT_EQ(pin.wheel_radius_mm, 300.0);
    EXPECT_EQ(pin.pin_angle_deg, 240.0);
    EXPECT_EQ(pin.gauge_offset_deg, 180.0) << "default";
    EXPECT_EQ(pin.tolerances.roundness_um.lower, std::nullopt) << "upper limit only";
    EXPECT_EQ(pin.tolerances.roundness_um.upper, 4.0);
    EXPECT_EQ(pin.tolerances.diameter_error_um.lower, -5.0);
    EXPECT_EQ(pin.tolerances.diameter_error_um.upper, 8.0);
    EXPECT_EQ(pin.tolerances.stroke_error_um.lower, -25.0);
    EXPECT_EQ(pin.tolerances.stroke_error_um.upper, 25.0);
    EXPECT_EQ(pin.tolerances.index_error_deg.lower, -0.03);
    EXPECT_EQ(pin.tolerances.index_error_deg.upper, 0.03);
    EXPECT_EQ(pf->part.name, "crank");
    EXPECT_EQ(pf->part.lobe, 3) << "the pin number";
    EXPECT_EQ(pf->part.wheel_radius_mm, 300.0);
    EXPECT_TRUE(pf->part.lift_table.empty());
    EXPECT_EQ(pf->nc_program, "CRANK_PIN3");
    EXPECT_FALSE(pf->speed.has_value());
  }
}

TEST(PinPartFile, AGaugeOffsetAndACxSpeedProgramAreRead) {
  Result<PartFile> pf = parse_pin(pin_part("c-x", "", "[speed]\nlobe_speed_mm_per_min = 20000.0\n"));
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  ASSERT_TRUE(pf->speed.has_value());
  EXPECT_EQ(pf->speed->lobe_speed_mm_per_min, 20000.0);

  std::string text = pin_part();
  text.insert(text.find("[pin.tolerance]"), "gauge_offset_deg = 90.0\n");
  Result<PartFile> offset = parse_pin(text);
  ASSERT_TRUE(offset.ok()) << offset.error().message;
  EXPECT_EQ(offset->pin->gauge_offset_deg, 90.0);
}

TEST(PinPartFile, ALobeFileHasNoPin) {
  Result<PartFile> pf = parse_pin(
      "name = \"intake\"\nlift_table = \"intake.csv\"\nfollower = \"flat\"\nbase_circle_radius_mm = 18.0\n"
      "wheel_radius_mm = 200.0\nnc_program = \"CAM\"\n");
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  EXPECT_FALSE(pf->pin.has_value());
}

TEST(PinPartFile, TheSamplePinsRead) {
  for (const auto& [file, mode, program] : {std::tuple{"crankpin_cx.toml", PinMode::kCX, "CRANK_PIN1"},
                                            std::tuple{"crankpin_cxy.toml", PinMode::kCXY, "CRANK_PIN1_XY"}}) {
    Result<PartFile> pf = read_part_file(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/" + file);
    ASSERT_TRUE(pf.ok()) << pf.error().message;
    ASSERT_TRUE(pf->pin.has_value()) << file;
    EXPECT_EQ(pf->pin->mode, mode) << file;
    EXPECT_EQ(pf->pin->throw_mm, 45.0);
    EXPECT_EQ(pf->pin->pin_radius_mm, 25.0);
    EXPECT_EQ(pf->pin->wheel_radius_mm, 300.0);
    EXPECT_EQ(pf->pin->pin_angle_deg, 0.0);
    EXPECT_EQ(pf->pin->tolerances.roundness_um.upper, 4.0);
    EXPECT_EQ(pf->pin->tolerances.diameter_error_um.upper, 8.0);
    EXPECT_EQ(pf->pin->tolerances.stroke_error_um.lower, -25.0);
    EXPECT_EQ(pf->pin->tolerances.index_error_deg.upper, 0.03);
    EXPECT_EQ(pf->part.lobe, 1);
    EXPECT_EQ(pf->nc_program, program);
    EXPECT_FALSE(pf->speed.has_value()) << file;
  }
}

TEST(PinPartFile, RefusesMistakesNamingFileLineAndKey) {
  struct Case {
    std::string text;
    std::string expected;
  };
  std::string no_mode = pin_part();
  no_mode.erase(no_mode.find("mode = \"c-x\"\n"), 13);
  std::string bad_number = pin_part();
  bad_number.replace(bad_number.find("pin_number = 3"), 14, "pin_number = 0");
  std::string bad_program = pin_part();
  bad_program.replace(bad_program.find("\"CRANK_PIN3\""), 12, "\"9PIN\"");
  const Case cases[] = {
      {pin_part("c-x", "lift_table = \"pin.csv\"\n"),
       "pin.toml:4: key `lift_table`: a lobe's key, and this file describes a crankpin ([pin]); remove it"},
      {pin_part("c-x", "base_circle_radius_mm = 25.0\n"), "pin.toml:4: key `base_circle_radius_mm`: a lobe's key"},
      {pin_part("c-x", "follower = \"flat\"\n"), "pin.toml:4: key `follower`: a lobe's key"},
      {pin_part("c-x", "lobe = 2\n"),
       "pin.toml:4: key `lobe`: a lobe's key, and this file describes a crankpin "
       "([pin]); give the pin's number as pin_number"},
      {pin_part("c-x", "wheel_radius_mm = 300.0\n"),
       "pin.toml:4: key `wheel_radius_mm`: a lobe's key, and this file "
       "describes a crankpin ([pin]); give it in [pin]"},
      {pin_part("c-x", "[tolerance]\nroundness_um = 4.0\n"),
       "pin.toml:4: key `tolerance`: a lobe's key, and this file describes a crankpin ([pin]); give a pin's "
       "tolerances in [pin.tolerance]"},
      {pin_part("c-x", "colour = \"red\"\n"),
       "pin.toml:4: key `colour`: unknown key; known keys: name, pin_number, nc_program, speed, pin"},
      {pin_part("c-x", "", "[pin.extra]\n"), "key `pin.extra`: unknown key"},
      {pin_part("c-x-z"), "pin.toml:9: key `pin.mode`: `c-x-z` is not one of c-x, c-x-y"},
      {no_mode, "pin.toml: key `pin.mode` is missing; it is required"},
      {bad_number, "pin.toml:2: key `pin_number`"},
      {pin_part("c-x-y", "[speed]\nlobe_speed_mm_per_min = 20000.0\n"),
       "pin.toml:4: key `speed`: a pin ground C-X-Y keeps its grinding-point speed constant at a constant C speed, "
       "so it has no speed program; remove [speed], or grind the pin with mode = \"c-x\""},
      {bad_program, "pin.toml:3: key `nc_program`: `9PIN` is not a valid NC program name"},
  };
  for (const Case& c : cases) EXPECT_TRUE(refused(parse_pin(c.text), c.expected)) << c.text;
}

TEST(PinPartFile, RefusesABadToleranceNamingItsLineAndKey) {
  std::string range = pin_part();
  range.replace(range.find("roundness_um = 4.0"), 18, "roundness_um = [-1.0, 4.0]");
  EXPECT_TRUE(refused(parse_pin(range),
                      "pin.toml:11: key `pin.tolerance.roundness_um`: [lower, upper] is not allowed "
                      "here; it has an upper limit only"));
  std::string reversed = pin_part();
  reversed.replace(reversed.find("[-5.0, 8.0]"), 11, "[8.0, -5.0]");
  EXPECT_TRUE(refused(parse_pin(reversed),
                      "pin.toml:12: key `pin.tolerance.diameter_error_um`: lower limit 8 is not "
                      "below upper limit -5"));
  std::string negative = pin_part();
  negative.replace(negative.find("stroke_error_um = 25.0"), 22, "stroke_error_um = -25.0");
  EXPECT_TRUE(refused(parse_pin(negative), "pin.toml:13: key `pin.tolerance.stroke_error_um`: -25 is not a tolerance"));
  std::string unknown = pin_part("c-x", "", "lift_error_um = 5.0\n");
  EXPECT_TRUE(refused(parse_pin(unknown),
                      "pin.toml:15: key `pin.tolerance.lift_error_um`: unknown key; known keys: "
                      "roundness_um, diameter_error_um, stroke_error_um, index_error_deg"));
}

TEST(PinPartFile, APinTheWheelCannotReachIsRefusedWithTheFileAndTheThrowsLine) {
  std::string text = pin_part();
  text.replace(text.find("throw_mm = 45.0"), 15, "throw_mm = 400.0");
  EXPECT_TRUE(refused(parse_pin(text),
                      "pin.toml:5: pin: throw_mm = 400.0000 must be less than pin_radius_mm + "
                      "wheel_radius_mm = 325.0000"));
  std::string zero = pin_part();
  zero.replace(zero.find("pin_radius_mm = 25.0"), 20, "pin_radius_mm = 0.0");
  EXPECT_TRUE(refused(parse_pin(zero), "pin.toml:6: key `pin.pin_radius_mm`"));
}

}  // namespace
}  // namespace gaugeloop

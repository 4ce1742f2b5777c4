// `gaugeloop profile` with the grinding-point speed, at a constant work speed and at a speed
// program: the real binary, its CSV and JSON.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/cli.h"
#include "tests/support/csv_reader.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

using testing::CommandResult;
using testing::run_shell;

// stdout only: the CSV and JSON are parsed whole.
CommandResult profile(const std::string& args) {
  return run_shell(testing::gaugeloop_binary() + " profile --part " + std::string(GAUGELOOP_SOURCE_DIR) +
                   "/examples/intake_flat.toml " + args + " 2>/dev/null; true");
}

using Csv = testing::NumericCsv;
constexpr auto parse_csv = testing::read_numeric_csv;

// rb = 18 mm on the base circle: 2 pi rb n mm/min.
constexpr double kBaseCircleAt60RpmMmPerMin = 2.0 * std::numbers::pi * 18.0 * 60.0;

TEST(ProfileSpeed, AtAConstantSpeedTheGrindingPointSpeedIsTheBaseCircleTimesTheSpeedThere) {
  const Csv csv = parse_csv(profile("--step-deg 1 --frame machine --speed-rpm 60").output);
  EXPECT_EQ(csv.header,
            "c_deg,x_mm,dx_dc_mm_per_deg,d2x_dc2_mm_per_deg2,v_mm_per_s,a_mm_per_s2,grinding_point_speed_mm_per_min");
  ASSERT_EQ(csv.rows.size(), 360u);
  EXPECT_NEAR(csv.rows[180][6], kBaseCircleAt60RpmMmPerMin, 1e-6);
  // The flanks run faster than the base circle at constant speed, the nose slower.
  double largest = 0.0;
  for (const auto& row : csv.rows) largest = std::max(largest, row[6]);
  EXPECT_GT(largest, 1.5 * kBaseCircleAt60RpmMmPerMin);
  EXPECT_LT(csv.rows[0][6], kBaseCircleAt60RpmMmPerMin);
}

TEST(ProfileSpeed, TheSpeedProgramHoldsTheLobeSpeedWithinTheSlidesLimits) {
  const Csv csv = parse_csv(profile("--step-deg 0.5 --frame machine --speed-rpm 60 --speed-program").output);
  EXPECT_EQ(csv.header,
            "c_deg,x_mm,dx_dc_mm_per_deg,d2x_dc2_mm_per_deg2,c_speed_rpm,v_mm_per_s,a_mm_per_s2,"
            "grinding_point_speed_mm_per_min");
  ASSERT_EQ(csv.rows.size(), 720u);
  int at_target = 0;
  for (const auto& row : csv.rows) {
    ASSERT_EQ(row.size(), 8u);
    EXPECT_LE(row[4], 60.0 + 1e-9);
    EXPECT_LE(std::abs(row[5]), 300.0);
    EXPECT_LE(std::abs(row[6]), 20000.0 * (1.0 + 1e-9));
    if (row[1] > 0.01) {
      EXPECT_LE(row[7], 2000.0 + 1e-6) << row[0];
      if (std::abs(row[7] - 2000.0) < 1e-3) ++at_target;
    }
  }
  EXPECT_GT(at_target, 200);
  EXPECT_NEAR(csv.rows[360][4], 60.0, 1e-9);  // the base circle keeps its speed
  EXPECT_NEAR(csv.rows[360][7], kBaseCircleAt60RpmMmPerMin, 1e-6);
}

TEST(ProfileSpeed, JsonCarriesTheProgramAndItsCycleTime) {
  const CommandResult r = profile("--step-deg 1 --format json --speed-program --lobe-speed-mm-per-min 3000");
  const nlohmann::json j = nlohmann::json::parse(r.output);
  ASSERT_TRUE(j["speed_program"].is_object()) << r.output;
  EXPECT_EQ(j["speed_program"]["lobe_speed_mm_per_min"], 3000.0);
  EXPECT_EQ(j["speed_program"]["base_speed_rpm"], 60.0);
  EXPECT_DOUBLE_EQ(j["speed_program"]["constant_cycle_time_s"].get<double>(), 1.0);
  EXPECT_GT(j["speed_program"]["cycle_time_s"].get<double>(), 1.2);
  double largest = 0.0;
  for (const auto& p : j["points"]) {
    largest = std::max(largest, p["grinding_point_speed_mm_per_min"].get<double>());
    EXPECT_GT(p["c_speed_rpm"].get<double>(), 0.0);
  }
  // The base circle is now the fastest: 6786 mm/min at 60 rpm.
  EXPECT_NEAR(j["peak_abs"]["grinding_point_speed_mm_per_min"].get<double>(), largest, 1e-9);
  EXPECT_NEAR(largest, kBaseCircleAt60RpmMmPerMin, 1.0);
}

// The part file's [speed] is the program's default; the flags override it.
TEST(ProfileSpeed, ThePartFilesSpeedSectionIsTheDefault) {
  testing::TempDir dir("profile-speed");
  const std::string source = std::string(GAUGELOOP_SOURCE_DIR) + "/examples/";
  std::string text = testing::slurp(source + "intake_flat.toml");
  text.replace(text.find("intake_flat.csv"), 15, source + "intake_flat.csv");
  const auto part = dir.write("slow.toml", text + "\n[speed]\nlobe_speed_mm_per_min = 1500\nbase_speed_rpm = 30\n");
  auto run = [&](const std::string& args) {
    return run_shell(testing::gaugeloop_binary() + " profile --part " + part.string() +
                     " --step-deg 1 --format json --speed-program " + args + " 2>&1");
  };
  CommandResult r = run("");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["speed_program"]["lobe_speed_mm_per_min"], 1500.0);
  EXPECT_EQ(j["speed_program"]["base_speed_rpm"], 30.0);
  EXPECT_DOUBLE_EQ(j["speed_program"]["constant_cycle_time_s"].get<double>(), 2.0);
  r = run("--lobe-speed-mm-per-min 2500 --speed-rpm 45");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["speed_program"]["lobe_speed_mm_per_min"], 2500.0);
  EXPECT_EQ(j["speed_program"]["base_speed_rpm"], 45.0);
}

}  // namespace
}  // namespace gaugeloop

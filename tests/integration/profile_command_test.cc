// `gaugeloop profile` run as a user would: the wheel path with its velocity and acceleration,
// in CSV and JSON, cam and machine frame, and the refusals, each with exit status 2.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "core/lift_table.h"
#include "core/part.h"
#include "tests/support/cli.h"
#include "tests/support/csv_reader.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using testing::CommandResult;
using testing::run_command;
using testing::run_command_stdout;

std::string example(const std::string& file) { return std::string(GAUGELOOP_SOURCE_DIR) + "/examples/" + file; }

// CSV rows after the header, as numbers.
using Csv = testing::NumericCsv;
constexpr auto parse_csv = testing::read_numeric_csv;

// The same path from the library, for the part the example file describes.
WheelPath library_path(const std::string& csv_file, const Part& part, double step_deg) {
  Result<LiftTable> table = read_lift_table_csv(example(csv_file));
  EXPECT_TRUE(table.ok());
  Result<PeriodicSpline> lift = PeriodicSpline::fit(table->angle_deg, table->lift_mm);
  EXPECT_TRUE(lift.ok());
  Result<WheelPath> path = compute_wheel_path(*lift, part, step_deg);
  EXPECT_TRUE(path.ok()) << path.error().message;
  return path.ok() ? *path : WheelPath{};
}

Part intake_part() {
  Part p;
  p.name = "intake_flat";
  p.base_circle_radius_mm = 18.0;
  p.wheel_radius_mm = 200.0;
  return p;
}

class ProfileCommandTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = tmp_.path(); }

  // A part file in the test directory: `body` plus the lift table of an example, by path.
  std::string write_part(const std::string& name, const std::string& csv_file, const std::string& body) {
    const fs::path path = dir_ / (name + ".toml");
    std::ofstream(path) << "name = \"" << name << "\"\nlift_table = \"" << example(csv_file) << "\"\n"
                        << "nc_program = \"CAM_TEST\"\n"
                        << body;
    return path.string();
  }

  testing::TempDir tmp_;  // before everything that lives in it
  fs::path dir_;
};

TEST_F(ProfileCommandTest, PrintsTheWheelPathAsCsvAtTheStepAsked) {
  CommandResult r = run_command_stdout("profile --part " + example("intake_flat.toml") + " --step-deg 0.5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Csv csv = parse_csv(r.output);
  EXPECT_EQ(csv.header, "psi_deg,x_mm,dx_dpsi_mm_per_deg,d2x_dpsi2_mm_per_deg2");
  ASSERT_EQ(csv.rows.size(), 720u);
  const WheelPath path = library_path("intake_flat.csv", intake_part(), 0.5);
  ASSERT_EQ(path.x_mm.size(), 720u);
  for (size_t k = 0; k < csv.rows.size(); ++k) {
    ASSERT_EQ(csv.rows[k].size(), 4u);
    EXPECT_DOUBLE_EQ(csv.rows[k][0], 0.5 * static_cast<double>(k));
    // Printed with 10 significant digits: 1e-9 mm on X up to 8.5 mm, 1e-11 on derivatives
    // below 0.2 mm/deg (plus 1e-12 absolute where they pass through 0).
    EXPECT_NEAR(csv.rows[k][1], path.x_mm[k], 1e-9) << k;
    EXPECT_NEAR(csv.rows[k][2], path.dx_dpsi_mm_per_deg[k], 1e-10) << k;
    EXPECT_NEAR(csv.rows[k][3], path.d2x_dpsi2_mm_per_deg2[k], 1e-10) << k;
  }
  EXPECT_NEAR(csv.rows[0][1], 8.5, 1e-9);    // the nose
  EXPECT_NEAR(csv.rows[360][1], 0.0, 1e-9);  // the base circle, psi 180
}

TEST_F(ProfileCommandTest, AddsSlideVelocityAndAccelerationAtAWorkSpeed) {
  // 60 rpm: C turns 360 deg/s, so v = 360 dX/dpsi (rotation_sense 1), a = 360^2 d2X/dpsi2.
  CommandResult r =
      run_command_stdout("profile --part " + example("exhaust_roller.toml") + " --step-deg 1 --speed-rpm 60");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Csv csv = parse_csv(r.output);
  EXPECT_EQ(csv.header,
            "psi_deg,x_mm,dx_dpsi_mm_per_deg,d2x_dpsi2_mm_per_deg2,v_mm_per_s,a_mm_per_s2,"
            "grinding_point_speed_mm_per_min");
  ASSERT_EQ(csv.rows.size(), 360u);
  double peak_a = 0.0;
  for (const std::vector<double>& row : csv.rows) {
    ASSERT_EQ(row.size(), 7u);
    EXPECT_NEAR(row[4], 360.0 * row[2], 1e-9 * std::max(1.0, std::abs(row[4])));
    EXPECT_NEAR(row[5], 129600.0 * row[3], 1e-9 * std::max(1.0, std::abs(row[5])));
    peak_a = std::max(peak_a, std::abs(row[5]));
  }
  EXPECT_GT(peak_a, 100.0);  // a lobe at 60 rpm asks the slide for m/s^2, not um/s^2
}

TEST_F(ProfileCommandTest, PrintsJsonWithThePartAndThePeaks) {
  CommandResult r = run_command_stdout("profile --part " + example("intake_flat.toml") +
                                       " --step-deg 1 --format json --speed-rpm -30");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["part"], "intake_flat");
  EXPECT_EQ(j["frame"], "cam");
  EXPECT_EQ(j["follower"], "flat");
  EXPECT_EQ(j["speed_rpm"], -30.0);
  ASSERT_EQ(j["points"].size(), 360u);
  double peak_v = 0.0;
  for (const auto& p : j["points"]) {
    // C turning down at 30 rpm: -180 deg/s.
    EXPECT_NEAR(p["v_mm_per_s"].get<double>(), -180.0 * p["dx_dpsi_mm_per_deg"].get<double>(), 1e-9);
    peak_v = std::max(peak_v, std::abs(p["v_mm_per_s"].get<double>()));
  }
  EXPECT_DOUBLE_EQ(j["peak_abs"]["v_mm_per_s"].get<double>(), peak_v);
  EXPECT_DOUBLE_EQ(j["peak_abs"]["x_mm"].get<double>(), 8.5);
}

TEST_F(ProfileCommandTest, MachineFrameRowsAreTheCamRowsAtPsiFromC) {
  // rotation_sense -1, c0 37 deg: the row at C is the cam-frame row at psi = -(C - 37).
  const std::string part = write_part("turned", "intake_flat.csv",
                                      "follower = \"flat\"\nbase_circle_radius_mm = 18.0\nwheel_radius_mm = 200.0\n"
                                      "rotation_sense = -1\nc_offset_deg = 37.0\n");
  CommandResult cam = run_command_stdout("profile --part " + part + " --step-deg 1");
  CommandResult machine = run_command_stdout("profile --part " + part + " --step-deg 1 --frame machine");
  ASSERT_EQ(cam.exit_code, 0) << cam.output;
  ASSERT_EQ(machine.exit_code, 0) << machine.output;
  const Csv by_psi = parse_csv(cam.output);
  const Csv by_c = parse_csv(machine.output);
  EXPECT_EQ(by_c.header, "c_deg,x_mm,dx_dc_mm_per_deg,d2x_dc2_mm_per_deg2");
  ASSERT_EQ(by_c.rows.size(), 360u);
  for (size_t c = 0; c < 360; ++c) {
    const size_t psi = static_cast<size_t>((360 + 37 - static_cast<int>(c)) % 360);
    EXPECT_EQ(by_c.rows[c][0], static_cast<double>(c));
    EXPECT_NEAR(by_c.rows[c][1], by_psi.rows[psi][1], 1e-9) << c;
    EXPECT_NEAR(by_c.rows[c][2], -by_psi.rows[psi][2], 1e-10) << c;  // dX/dC = s dX/dpsi
    EXPECT_NEAR(by_c.rows[c][3], by_psi.rows[psi][3], 1e-10) << c;
  }
}

TEST_F(ProfileCommandTest, RefusesAWheelTooLargeForTheExhaustRollersConcaveFlanks) {
  // examples/exhaust_roller.toml with a 100 mm wheel instead of 45 mm.
  const std::string part = write_part("exhaust_roller_100", "exhaust_roller.csv",
                                      "follower = \"roller\"\nfollower_radius_mm = 11.0\nbase_circle_radius_mm = 17.0\n"
                                      "wheel_radius_mm = 100.0\n");
  CommandResult r = run_command("profile --part " + part + " --step-deg 1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr(part));
  EXPECT_THAT(r.output, HasSubstr("wheel radius 100.000 mm cannot grind"));
  EXPECT_THAT(r.output, HasSubstr("cam angle"));
  EXPECT_THAT(r.output, HasSubstr("largest wheel that fits"));
  EXPECT_THAT(r.output, ::testing::Not(HasSubstr("psi_deg")));  // no half a table

  CommandResult fits = run_command_stdout("profile --part " + example("exhaust_roller.toml") + " --step-deg 1");
  EXPECT_EQ(fits.exit_code, 0);
}

TEST_F(ProfileCommandTest, ReportsAMissingPartABadStepAndABadSpeedWithStatus2) {
  const std::string missing = (dir_ / "no_such_part.toml").string();
  CommandResult r = run_command("profile --part " + missing + " --step-deg 1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr(missing));

  r = run_command("profile --part " + example("intake_flat.toml") + " --step-deg 0.7");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("0.700000 deg does not divide 360"));

  r = run_command("profile --part " + example("intake_flat.toml") + " --step-deg 0");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("out of range"));

  r = run_command("profile --part " + example("intake_flat.toml") + " --step-deg 1 --speed-rpm 0");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("--speed-rpm"));

  r = run_command("profile --part " + example("intake_flat.toml") + " --step-deg 1 --format xml");
  EXPECT_EQ(r.exit_code, 2) << r.output;

  r = run_command("profile --step-deg 1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("--part"));
}

}  // namespace
}  // namespace gaugeloop

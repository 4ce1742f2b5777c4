// The service's configuration with crankpin parts: the Y table's template, the main programs
// of the two modes, the Y table numbers and the Y slide's limits of [nc], and the pin parts
// checked as they are read. The files are written into a fresh directory per test.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "config/service_config.h"
#include "tests/support/refused.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

using testing::refused;

namespace fs = std::filesystem;

const fs::path kPinExamples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";

// Line 1 [gauge], 2-3 a C-X pin, 4-5 a C-X-Y pin; [nc] starts at line 6.
const std::string kPins =
    "[gauge]\n"
    "[[part]]\nfile = \"parts/crankpin_cx.toml\"\n"
    "[[part]]\nfile = \"parts/crankpin_cxy.toml\"\n";
// Lines 6-13: the X slide of a crankpin grinder (it swings twice the 45 mm throw each turn).
const std::string kPinNc =
    "[nc]\n"
    "template = \"table.spf\"\n"
    "pin_main_template = \"pin_main_cx.mpf\"\n"
    "pin_main_xy_template = \"pin_main.mpf\"\n"
    "x_min_mm = -1.0\n"
    "x_max_mm = 95.0\n"
    "x_velocity_max_mm_per_s = 600.0\n"
    "x_acceleration_max_mm_per_s2 = 30000.0\n";

class ServicePinTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(dir_.path() / "parts");
    for (const char* name : {"crankpin_cx.toml", "crankpin_cxy.toml"}) {
      fs::copy_file(kPinExamples / name, dir_.path() / "parts" / name);
    }
    fs::copy_file(kPinExamples / "sinumerik" / "cam_table.spf", dir_.path() / "table.spf");
    for (const char* name : {"pin_y_table.spf", "pin_main.mpf", "pin_main_cx.mpf"}) {
      fs::copy_file(kPinExamples / "sinumerik" / name, dir_.path() / name);
    }
  }

  Result<ServiceConfig> read(const std::string& text) { return read_service_config(dir_.write("svc.toml", text)); }

  // "<dir>/svc.toml:<line>: key `<key>`", as a message starts.
  std::string at(int line, const std::string& key) const {
    return (dir_.path() / "svc.toml").string() + ":" + std::to_string(line) + ": key `" + key + "`";
  }

  testing::TempDir dir_;
};

TEST_F(ServicePinTest, PinPartsAreReadWithTheYTableAndTheMainProgramOfTheirMode) {
  auto c = read(kPins + kPinNc +
                "y_template = \"pin_y_table.spf\"\n"
                "y_table_numbers = [7, 8]\n"
                "y_min_mm = -50.0\n"
                "y_max_mm = 50.0\n"
                "y_velocity_max_mm_per_s = 550.0\n"
                "y_acceleration_max_mm_per_s2 = 25000.0\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_EQ(c->parts.size(), 2u);
  EXPECT_EQ(c->job.y_table_numbers, (TableNumbers{7, 8}));
  EXPECT_EQ(c->job.y_axis_limits.x_min_mm, -50.0);
  EXPECT_EQ(c->job.y_axis_limits.x_max_mm, 50.0);
  EXPECT_EQ(c->job.y_axis_limits.x_velocity_max_mm_per_s, 550.0);
  EXPECT_EQ(c->job.y_axis_limits.x_acceleration_max_mm_per_s2, 25000.0);

  const JobSettings cx = job_for(*c, c->parts[0]);
  ASSERT_TRUE(cx.pin.has_value());
  EXPECT_EQ(cx.pin->mode, PinMode::kCX);
  EXPECT_EQ(cx.pin->throw_mm, 45.0);
  EXPECT_EQ(cx.nc_program, "CRANK_PIN1");
  EXPECT_EQ(cx.nc_main_template_name, (dir_.path() / "pin_main_cx.mpf").string());
  EXPECT_EQ(cx.nc_main_template.find("EGON(Y"), std::string::npos) << "C-X couples X alone";

  const JobSettings cxy = job_for(*c, c->parts[1]);
  ASSERT_TRUE(cxy.pin.has_value());
  EXPECT_EQ(cxy.pin->mode, PinMode::kCXY);
  EXPECT_EQ(cxy.nc_program, "CRANK_PIN1_XY");
  EXPECT_EQ(cxy.nc_main_template_name, (dir_.path() / "pin_main.mpf").string());
  EXPECT_NE(cxy.nc_main_template.find("EGON(Y"), std::string::npos) << "C-X-Y couples Y too";
  EXPECT_EQ(cxy.nc_y_template_name, (dir_.path() / "pin_y_table.spf").string());
  EXPECT_NE(cxy.nc_y_template.find("CTABDEF(Y,C,"), std::string::npos);
  EXPECT_EQ(cxy.y_table_numbers, (TableNumbers{7, 8}));
}

TEST_F(ServicePinTest, WithoutPinKeysTheYTableTakesItsDefaults) {
  auto c = read("[gauge]\n[[part]]\nfile = \"parts/crankpin_cx.toml\"\n" + kPinNc);
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->job.y_table_numbers, (TableNumbers{3, 4}));
  EXPECT_EQ(c->job.y_axis_limits.x_min_mm, -60.0);
  EXPECT_EQ(c->job.y_axis_limits.x_max_mm, 60.0);
  EXPECT_TRUE(c->job.nc_y_template.empty());
}

TEST_F(ServicePinTest, YTableNumbersThatOverlapTheXTablesAreRefusedNamingTheKeyAndLine) {
  EXPECT_TRUE(refused(read(kPins + kPinNc + "y_template = \"pin_y_table.spf\"\ny_table_numbers = [2, 5]\n"),
                      at(15, "nc.y_table_numbers") + ": table 2 would hold both a pin's X table and its Y table"));
}

// The Y tables' numbers left at their default (3 and 4) bind only a C-X-Y pin: a service with
// a C-X pin alone may give its X tables 3, one with a C-X-Y pin may not.
TEST_F(ServicePinTest, DefaultYTableNumbersUnderTheXTablesAreRefusedOnlyForACxyPin) {
  auto cx = read("[gauge]\n[[part]]\nfile = \"parts/crankpin_cx.toml\"\n" + kPinNc + "table_numbers = [3, 9]\n");
  ASSERT_TRUE(cx.ok()) << cx.error().message;
  EXPECT_EQ(cx->job.table_numbers, (TableNumbers{3, 9}));
  EXPECT_TRUE(refused(read(kPins + kPinNc + "y_template = \"pin_y_table.spf\"\ntable_numbers = [3, 9]\n"),
                      at(5, "part.file") +
                          ": part crankpin_cxy is a C-X-Y pin, and its Y tables would go to table 3, which [nc] "
                          "table_numbers gives the X tables; give [nc] y_table_numbers two numbers"));
}

TEST_F(ServicePinTest, AYSlideWhoseMaximumIsNotAboveItsMinimumIsRefused) {
  EXPECT_TRUE(refused(read(kPins + kPinNc + "y_template = \"pin_y_table.spf\"\ny_min_mm = 10.0\ny_max_mm = 10.0\n"),
                      at(16, "nc.y_max_mm") + ": must be above y_min_mm"));
}

TEST_F(ServicePinTest, ACxyPinWithoutAYTemplateIsRefusedAtReadingSayingWhatToGive) {
  auto c = read(kPins + kPinNc);
  EXPECT_TRUE(refused(c, at(5, "part.file")));
  EXPECT_TRUE(refused(c, "crankpin_cxy is a C-X-Y pin, but no Y table template is set"));
  EXPECT_TRUE(refused(c, "give one (examples/sinumerik/pin_y_table.spf, [nc] y_template)"));
}

// A pin's tables keep their own command position error bound, 0.1 um unless [nc]
// pin_command_error_um says otherwise; the lobes keep [nc] command_error_um.
TEST_F(ServicePinTest, PinTablesKeepTheirOwnCommandErrorBound) {
  auto c = read(kPins + kPinNc + "y_template = \"pin_y_table.spf\"\ncommand_error_um = 0.4\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->job.table_choice.bound_um, 0.4);
  EXPECT_EQ(job_for(*c, c->parts[0]).table_choice.bound_um, kPinCommandErrorBoundUm);
  EXPECT_EQ(job_for(*c, c->parts[1]).table_choice.bound_um, kPinCommandErrorBoundUm);
  auto set = read(kPins + kPinNc + "y_template = \"pin_y_table.spf\"\npin_command_error_um = 0.25\n");
  ASSERT_TRUE(set.ok()) << set.error().message;
  EXPECT_EQ(job_for(*set, set->parts[1]).table_choice.bound_um, 0.25);
}

}  // namespace
}  // namespace gaugeloop

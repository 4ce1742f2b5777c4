// The service's configuration file: every table read back, and every refusal naming the file,
// the line and the key. The files are written into a fresh directory per test.
#include "config/service_config.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/refused.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

using testing::refused;

namespace fs = std::filesystem;

const fs::path kExamples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";

// The parts used below, in the order of their [[part]] entries' lines: line 2 [[part]], line 3
// file (and line 4 plc_part_number when given).
const std::string kIntake = "[[part]]\nfile = \"parts/intake_flat.toml\"\n";
const std::string kExhaust = "[[part]]\nfile = \"parts/exhaust_roller.toml\"\n";
const std::string kNc = "[nc]\ntemplate = \"table.spf\"\n";
// 64 hex characters, as `gaugeloop token new` writes: 256 bits.
constexpr const char* kStrongToken = "9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08";

class ServiceConfigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // The sample parts and the Sinumerik template, copied so relative paths are relative to
    // this directory.
    for (const char* name : {"intake_flat.toml", "intake_flat.csv", "exhaust_roller.toml", "exhaust_roller.csv"}) {
      fs::create_directories(dir_.path() / "parts");
      fs::copy_file(kExamples / name, dir_.path() / "parts" / name);
    }
    fs::copy_file(kExamples / "sinumerik" / "cam_table.spf", dir_.path() / "table.spf");
  }

  // A file only its owner may read or write (0600, as `gaugeloop token new` makes it), or `mode`.
  fs::path write_secret(const fs::path& relative, const std::string& text, mode_t mode = 0600) const {
    const fs::path p = dir_.write(relative, text);
    ::chmod(p.c_str(), mode);
    return p;
  }

  Result<ServiceConfig> read(const std::string& text) { return read_service_config(dir_.write("svc.toml", text)); }

  // "<dir>/svc.toml:<line>: key `<key>`", as a message starts.
  std::string at(int line, const std::string& key) const {
    return (dir_.path() / "svc.toml").string() + ":" + std::to_string(line) + ": key `" + key + "`";
  }

  testing::TempDir dir_;
};

TEST_F(ServiceConfigTest, AMinimalFileTakesTheDocumentedDefaults) {
  auto c = read("[gauge]\n" + kIntake + kNc);
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->machine, "grinder-1");
  EXPECT_EQ(c->job.machine, "grinder-1");
  EXPECT_EQ(c->gauge.host, "127.0.0.1");
  EXPECT_EQ(c->gauge.port, 502);
  EXPECT_EQ(c->job.poller.mode, SamplingMode::kLatched);
  EXPECT_EQ(c->job.poller.revolutions, 3);
  EXPECT_EQ(c->job.analysis.base_circle_center_deg, 180.0);
  EXPECT_EQ(c->job.analysis.base_circle_half_width_deg, 30.0);
  EXPECT_EQ(c->job.compensation.gain, 1.0);
  EXPECT_TRUE(c->job.compensation.choose_harmonics);
  EXPECT_EQ(c->job.compensation.max_harmonic, 30);
  EXPECT_EQ(c->job.compensation.max_correction_um, 100.0);
  EXPECT_EQ(c->job.compensation.max_change_um, 50.0);
  EXPECT_EQ(c->job.compensation.max_repeatability_um, 2.0);
  EXPECT_EQ(c->job.compensation.max_phase_deg, 0.5);
  EXPECT_TRUE(c->job.build_on_table_in_force);
  EXPECT_EQ(c->integrity_check_hours, 24);
  EXPECT_EQ(c->job.nc_dir, dir_.path() / "nc");
  EXPECT_EQ(c->job.table_kind, TableKind::kAuto);
  EXPECT_EQ(c->job.table_step_deg, 1.0);
  EXPECT_EQ(c->job.table_choice.bound_um, 0.5);
  EXPECT_EQ(c->job.table_choice.max_step_deg, 10.0);
  EXPECT_TRUE(c->job.table_choice.allow_spline);
  EXPECT_FALSE(c->job.require_approval);
  EXPECT_EQ(c->job.table_numbers, (TableNumbers{1, 2}));
  EXPECT_TRUE(c->job.nc_main_template.empty()) << "no main program unless one is named";
  EXPECT_EQ(c->job.axis_limits.x_min_mm, -0.5);
  EXPECT_EQ(c->job.axis_limits.x_max_mm, 20.0);
  EXPECT_EQ(c->job.axis_limits.x_velocity_max_mm_per_s, 300.0);
  EXPECT_EQ(c->job.axis_limits.x_acceleration_max_mm_per_s2, 20000.0);
  EXPECT_EQ(c->job.axis_limits.speed_rpm, 60.0);
  EXPECT_EQ(c->job.db_path, dir_.path() / "gaugeloop.sqlite");
  EXPECT_FALSE(c->http.has_value());
  EXPECT_FALSE(c->plc.has_value());
  ASSERT_EQ(c->parts.size(), 1u);
  EXPECT_FALSE(c->parts[0].plc_part_number.has_value());
}

// The gauge's identity for the reports: a calibration day that is no day, or is still to come,
// is refused at its key.
TEST_F(ServiceConfigTest, TheGaugesIdAndCalibrationDayAreReadAndABadDayRefused) {
  auto c = read("[gauge]\nid = \"LVDT-07\"\ncalibration_date = \"2026-10-01\"\n" + kIntake + kNc);
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->job.gauge_id, "LVDT-07");
  EXPECT_EQ(c->job.gauge_calibration_date, "2026-10-01");
  for (const char* day : {"2026-02-30", "01.10.2026", "2999-01-01"}) {
    c = read("[gauge]\ncalibration_date = \"" + std::string(day) + "\"\n" + kIntake + kNc);
    ASSERT_FALSE(c.ok()) << day;
    EXPECT_NE(c.error().message.find(at(2, "gauge.calibration_date")), std::string::npos) << c.error().message;
    EXPECT_NE(c.error().message.find("is not a past day as YYYY-MM-DD"), std::string::npos) << c.error().message;
  }
}

TEST_F(ServiceConfigTest, AFullFileIsReadBackFieldByField) {
  dir_.write("gauge.toml", "[link]\nhost = \"127.0.0.1\"\nport = 1502\nunit_id = 9\n");
  write_secret("token", std::string(kStrongToken) + "\n");
  const std::string text = R"(machine = "grinder-7"
[gauge]
config = "gauge.toml"
mode = "live"
revolutions = 5
[[part]]
file = "parts/intake_flat.toml"
plc_part_number = 11
[[part]]
file = "parts/exhaust_roller.toml"
plc_part_number = 12
[analysis]
base_circle_center_deg = 170.0
base_circle_half_width_deg = 25
[compensation]
gain = 0.5
max_harmonic = 20
max_correction_um = 80.0
max_change_um = 40.0
max_repeatability_um = 3.0
max_phase_deg = 1.0
build_on_table_in_force = false
[nc]
dir = "out"
template = "table.spf"
table = "adaptive-spline"
table_step_deg = 0.5
command_error_um = 0.25
max_segment_deg = 5.0
allow_spline = false
require_approval = true
table_number = 7
x_min_mm = -1.0
x_max_mm = 25.0
x_velocity_max_mm_per_s = 250.0
x_acceleration_max_mm_per_s2 = 15000.0
work_speed_rpm = 50.0
[database]
path = "data/runs.sqlite"
[http]
host = "0.0.0.0"
port = 9090
token_file = "token"
[plc]
host = "127.0.0.1"
port = 1503
unit_id = 3
response_timeout_ms = 300
base_address = 200
poll_interval_ms = 50
)";
  auto c = read(text);
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->source, dir_.path() / "svc.toml");
  EXPECT_EQ(c->machine, "grinder-7");
  EXPECT_EQ(c->job.machine, "grinder-7");
  EXPECT_EQ(c->gauge.port, 1502);
  EXPECT_EQ(c->gauge.unit_id, 9);
  EXPECT_EQ(c->job.poller.mode, SamplingMode::kLive);
  EXPECT_EQ(c->job.poller.revolutions, 5);
  ASSERT_EQ(c->parts.size(), 2u);
  EXPECT_EQ(c->parts[0].file.part.name, "intake_flat");
  EXPECT_EQ(c->parts[0].plc_part_number, 11);
  EXPECT_EQ(c->parts[1].file.part.name, "exhaust_roller");
  EXPECT_EQ(c->parts[1].file.part.lobe, 2);
  EXPECT_EQ(c->parts[1].plc_part_number, 12);
  EXPECT_EQ(c->parts[1].file.nc_program, "CAM_EXHAUST_L2");
  EXPECT_FALSE(c->parts[1].design.lift_mm.empty());
  EXPECT_EQ(c->job.analysis.base_circle_center_deg, 170.0);
  EXPECT_EQ(c->job.analysis.base_circle_half_width_deg, 25.0) << "an integer is taken as a number";
  EXPECT_EQ(c->job.compensation.gain, 0.5);
  EXPECT_EQ(c->job.compensation.max_harmonic, 20);
  EXPECT_EQ(c->job.compensation.max_correction_um, 80.0);
  EXPECT_EQ(c->job.compensation.max_change_um, 40.0);
  EXPECT_EQ(c->job.compensation.max_repeatability_um, 3.0);
  EXPECT_EQ(c->job.compensation.max_phase_deg, 1.0);
  EXPECT_FALSE(c->job.build_on_table_in_force);
  EXPECT_EQ(c->job.nc_dir, dir_.path() / "out");
  EXPECT_EQ(c->job.nc_template_name, (dir_.path() / "table.spf").string());
  EXPECT_NE(c->job.nc_template.find("{{"), std::string::npos) << "the template's text is read";
  EXPECT_EQ(c->job.table_kind, TableKind::kAdaptiveSpline);
  EXPECT_EQ(c->job.table_step_deg, 0.5);
  EXPECT_EQ(c->job.table_choice.bound_um, 0.25);
  EXPECT_EQ(c->job.table_choice.max_step_deg, 5.0);
  EXPECT_FALSE(c->job.table_choice.allow_spline);
  EXPECT_TRUE(c->job.require_approval);
  EXPECT_EQ(c->job.table_numbers, (TableNumbers{7, 8})) << "the older single number N is read as [N, N + 1]";
  EXPECT_EQ(c->job.axis_limits.x_min_mm, -1.0);
  EXPECT_EQ(c->job.axis_limits.x_max_mm, 25.0);
  EXPECT_EQ(c->job.axis_limits.x_velocity_max_mm_per_s, 250.0);
  EXPECT_EQ(c->job.axis_limits.x_acceleration_max_mm_per_s2, 15000.0);
  EXPECT_EQ(c->job.axis_limits.speed_rpm, 50.0);
  EXPECT_EQ(c->job.db_path, dir_.path() / "data" / "runs.sqlite");
  ASSERT_TRUE(c->http.has_value());
  EXPECT_EQ(c->http->host, "0.0.0.0");
  EXPECT_EQ(c->http->port, 9090);
  EXPECT_EQ(c->http->token, kStrongToken) << "the token file's line end is not part of the token";
  ASSERT_TRUE(c->plc.has_value());
  EXPECT_EQ(c->plc->link.link.transport, ModbusTransport::kTcp);
  EXPECT_EQ(c->plc->link.link.host, "127.0.0.1");
  EXPECT_EQ(c->plc->link.link.port, 1503);
  EXPECT_EQ(c->plc->link.link.unit_id, 3);
  EXPECT_EQ(c->plc->link.link.response_timeout.count(), 300);
  EXPECT_EQ(c->plc->link.base_address, 200);
  EXPECT_FALSE(c->plc->link.part_temperature) << "a PLC program of the 37-word block by default";
  EXPECT_EQ(c->plc->poll_interval.count(), 50);
}

TEST_F(ServiceConfigTest, TheExampleConfigReads) {
  auto c = read_service_config(kExamples / "service" / "gaugeloop.toml");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(configured_parts(*c), "intake_flat lobe 1, exhaust_roller lobe 2");
  EXPECT_EQ(c->gauge.port, 1502) << "from ../gauges/simulator.toml";
  ASSERT_EQ(c->shafts.size(), 1u) << "[[shaft]] file = \"../camshaft.toml\"";
  EXPECT_EQ(c->shafts[0].name, "sample camshaft");
}

// [[shaft]]: each a shaft file, relative to the config; a missing or bad file, a shaft named
// twice and a key of another name are refused naming the file, the line and the key.
TEST_F(ServiceConfigTest, ShaftFilesAreReadAndCheckedAtStart) {
  const std::string base = "[gauge]\n" + kIntake + kNc;
  Result<ServiceConfig> c = read(base);
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_TRUE(c->shafts.empty()) << "none without [[shaft]]";

  const std::string shaft =
      "name = \"cell camshaft\"\nindex_tolerance_deg = 0.25\n"
      "[[lobe]]\npart = \"intake_flat.toml\"\nangle_deg = 0.0\n"
      "[[lobe]]\npart = \"exhaust_roller.toml\"\nangle_deg = 110.0\n";
  dir_.write("parts/shaft.toml", shaft);
  // Lines: 1 [gauge], 2-3 the intake part, 4-5 [nc], 6 [[shaft]], 7 file.
  c = read(base + "[[shaft]]\nfile = \"parts/shaft.toml\"\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_EQ(c->shafts.size(), 1u);
  EXPECT_EQ(c->shafts[0].name, "cell camshaft");
  ASSERT_EQ(c->shafts[0].lobes.size(), 2u);
  EXPECT_EQ(c->shafts[0].lobes[1].angle_deg, 110.0);

  EXPECT_TRUE(
      refused(read(base + "[[shaft]]\nfile = \"parts/none.toml\"\n"), ErrorCode::kNotFound, at(7, "shaft.file")));
  dir_.write("parts/bad_shaft.toml", "name = \"b\"\n");
  EXPECT_TRUE(refused(read(base + "[[shaft]]\nfile = \"parts/bad_shaft.toml\"\n"), at(7, "shaft.file")));
  EXPECT_TRUE(refused(read(base + "[[shaft]]\nfile = \"parts/shaft.toml\"\n[[shaft]]\nfile = "
                                  "\"parts/shaft.toml\"\n"),
                      "'cell camshaft' is named twice"));
  EXPECT_TRUE(refused(read(base + "[[shaft]]\npath = \"parts/shaft.toml\"\n"), "path"));
  EXPECT_TRUE(refused(read("shaft = \"parts/shaft.toml\"\n" + base), "[[shaft]] entries"));
}

// Paths in the file are relative to the file's directory, wherever the process runs; a part
// file's lift table is relative to the part file.
TEST_F(ServiceConfigTest, TheDatabasesIntegrityCheckIntervalIsReadAndBounded) {
  const std::string base = "[gauge]\n" + kIntake + kNc;
  Result<ServiceConfig> c = read(base + "[database]\nintegrity_check_hours = 6\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->integrity_check_hours, 6);
  EXPECT_TRUE(refused(read(base + "[database]\nintegrity_check_hours = 0\n"), "database.integrity_check_hours"));
  EXPECT_TRUE(refused(read(base + "[database]\nintegrity_check_days = 1\n"), "integrity_check_days"));
}

TEST_F(ServiceConfigTest, RelativePathsAreResolvedAgainstTheConfigsDirectory) {
  dir_.write("etc/gauge.toml", "[link]\nport = 1602\n");
  write_secret("etc/keys/token", kStrongToken);
  const fs::path config = dir_.write("etc/svc.toml", R"([gauge]
config = "gauge.toml"
[[part]]
file = "../parts/intake_flat.toml"
[nc]
dir = "out/nc"
template = "../table.spf"
[database]
path = "../var/runs.sqlite"
[http]
token_file = "keys/token"
)");
  const fs::path elsewhere = fs::current_path();
  fs::current_path(dir_.path() / "parts");
  auto c = read_service_config(config);
  fs::current_path(elsewhere);
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->gauge.port, 1602);
  EXPECT_EQ(c->parts.at(0).file.part.lift_table.lexically_normal(), dir_.path() / "parts" / "intake_flat.csv");
  EXPECT_EQ(c->job.nc_dir, dir_.path() / "etc" / "out" / "nc");
  EXPECT_EQ(c->job.nc_template_name, (dir_.path() / "table.spf").string());
  EXPECT_EQ(c->job.db_path, dir_.path() / "var" / "runs.sqlite");
  EXPECT_EQ(c->http->token, kStrongToken);
}

TEST_F(ServiceConfigTest, AMissingFileIsNotFoundAndSaysCheckConfig) {
  auto c = read_service_config(dir_.path() / "absent.toml");
  EXPECT_TRUE(refused(c, ErrorCode::kNotFound, (dir_.path() / "absent.toml").string() + ": no such file"));
  EXPECT_TRUE(refused(c, ErrorCode::kNotFound, "; check --config"));
}

TEST_F(ServiceConfigTest, ASyntaxErrorNamesTheFileAndLine) {
  EXPECT_TRUE(
      refused(read("[gauge]\n[[part]\n"), ErrorCode::kInvalidInput, (dir_.path() / "svc.toml").string() + ":2: "));
}

TEST_F(ServiceConfigTest, AMissingRequiredKeyIsNamed) {
  const std::string svc = (dir_.path() / "svc.toml").string();
  EXPECT_TRUE(refused(read("[gauge]\n[[part]]\nplc_part_number = 1\n" + kNc), ErrorCode::kInvalidInput,
                      svc + ": key `part.file` is missing; it is required"));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + "[nc]\ndir = \"nc\"\n"), ErrorCode::kInvalidInput,
                      svc + ": [nc] template is required"));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake), ErrorCode::kInvalidInput, svc + ": [nc] template is required"));
  EXPECT_TRUE(refused(read(kIntake + kNc), ErrorCode::kInvalidInput, svc + ": no [gauge] table"));
  EXPECT_TRUE(refused(read("[gauge]\n" + kNc), ErrorCode::kInvalidInput, svc + ": no [[part]] entries"));
  EXPECT_TRUE(refused(read("part = 3\n[gauge]\n" + kNc), ErrorCode::kInvalidInput, svc + ": no [[part]] entries"));
}

TEST_F(ServiceConfigTest, AValueOfTheWrongTypeIsRefused) {
  EXPECT_TRUE(refused(read("machine = 7\n[gauge]\n" + kIntake + kNc), ErrorCode::kInvalidInput,
                      at(1, "machine") + ": expected a string in quotes"));
  EXPECT_TRUE(refused(read("[gauge]\nrevolutions = 3.5\n" + kIntake + kNc), ErrorCode::kInvalidInput,
                      at(2, "gauge.revolutions") + ": expected a whole number"));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kNc + "require_approval = \"yes\"\n"), ErrorCode::kInvalidInput,
                      at(6, "nc.require_approval") + ": expected true or false (no quotes)"));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kNc + "x_min_mm = \"-1\"\n"), ErrorCode::kInvalidInput,
                      at(6, "nc.x_min_mm") + ": expected a number"));
  EXPECT_TRUE(refused(read("gauge = \"sim\"\n" + kIntake + kNc), ErrorCode::kInvalidInput,
                      at(1, "gauge") + ": expected a table ([gauge])"));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kNc + "[http]\nport = \"80\"\n"), ErrorCode::kInvalidInput,
                      at(7, "http.port") + ": expected a whole number"));
}

TEST_F(ServiceConfigTest, AnUnknownKeyIsRefusedListingTheKnownOnes) {
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + "[nc]\ntemplat = \"table.spf\"\n"), ErrorCode::kInvalidInput,
                      at(5, "nc.templat") + ": unknown key; known keys: dir, template, table,"));
  EXPECT_TRUE(refused(read("machin = \"m\"\n[gauge]\n" + kIntake + kNc), ErrorCode::kInvalidInput,
                      at(1, "machin") + ": unknown key; known keys: machine, gauge, part,"));
  EXPECT_TRUE(refused(read("[gauge]\nrevs = 3\n" + kIntake + kNc), ErrorCode::kInvalidInput,
                      at(2, "gauge.revs") + ": unknown key; known keys: config, mode, revolutions"));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + "lobe = 2\n" + kNc), ErrorCode::kInvalidInput,
                      at(4, "part.lobe") + ": unknown key; known keys: file, plc_part_number"));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kNc + "[database]\nfile = \"x.sqlite\"\n"), ErrorCode::kInvalidInput,
                      at(7, "database.file") + ": unknown key; known keys: path"));
}

TEST_F(ServiceConfigTest, TheHarmonicsFedBackAreChosenOrFixed) {
  const std::string ok = "[gauge]\n" + kIntake + kNc + "[compensation]\n";  // 6 lines
  auto c = read(ok + "harmonics = \"auto\"\nmax_harmonic = 24\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_TRUE(c->job.compensation.choose_harmonics);
  EXPECT_EQ(c->job.compensation.max_harmonic, 24);
  c = read(ok + "harmonics = 30\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_FALSE(c->job.compensation.choose_harmonics);
  EXPECT_EQ(c->job.compensation.max_harmonic, 30);
  EXPECT_TRUE(refused(read(ok + "harmonics = \"all\"\n"), ErrorCode::kInvalidInput, at(7, "compensation.harmonics")));
  EXPECT_TRUE(refused(read(ok + "harmonics = 181\n"), ErrorCode::kInvalidInput,
                      at(7, "compensation.harmonics") + ": 181 is out of range; allowed [0, 180]"));
  EXPECT_TRUE(refused(read(ok + "harmonics = 20\nmax_harmonic = 30\n"), ErrorCode::kInvalidInput,
                      at(8, "compensation.max_harmonic") + ": is the cap of harmonics = \"auto\""));
}

// A part file with [speed]: its job takes the speed program and [nc] main_speed_template; the
// speed subprogram's template is required, and a main program that does not call the speed
// subprogram is refused at start, naming the template.
TEST_F(ServiceConfigTest, APartWithASpeedProgramTakesTheSpeedTemplates) {
  std::ifstream in(dir_.path() / "parts" / "intake_flat.toml");
  const std::string intake((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  dir_.write("parts/intake_speed.toml", intake + "\n[speed]\nlobe_speed_mm_per_min = 2500.0\n");
  fs::copy_file(kExamples / "sinumerik" / "cam_speed.spf", dir_.path() / "speed.spf");
  fs::copy_file(kExamples / "sinumerik" / "cam_main.mpf", dir_.path() / "main.mpf");
  fs::copy_file(kExamples / "sinumerik" / "cam_main_speed.mpf", dir_.path() / "main_speed.mpf");
  const std::string ok = "[gauge]\n[[part]]\nfile = \"parts/intake_speed.toml\"\n" + kNc;  // 5 lines
  auto c = read(ok);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("[nc] speed_template"), std::string::npos) << c.error().message;
  c = read(ok + "speed_template = \"speed.spf\"\nmain_template = \"main.mpf\"\n");
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("main.mpf: the main program does not call the speed subprogram CAM_INTAKE_L1_SPEED"),
            std::string::npos)
      << c.error().message;
  c = read(ok +
           "speed_template = \"speed.spf\"\nmain_template = \"main.mpf\"\nmain_speed_template = \"main_speed.mpf\"\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  const JobSettings js = job_for(*c, c->parts.front());
  ASSERT_TRUE(js.speed.has_value());
  EXPECT_EQ(js.speed->lobe_speed_mm_per_min, 2500.0);
  EXPECT_EQ(js.nc_main_template_name, (dir_.path() / "main_speed.mpf").string());
  EXPECT_EQ(js.nc_speed_template_name, (dir_.path() / "speed.spf").string());
}

TEST_F(ServiceConfigTest, TheTablesAlternateBetweenTwoDistinctNumbers) {
  const std::string ok = "[gauge]\n" + kIntake + kNc;  // 5 lines
  auto c = read(ok + "table_numbers = [5, 3]\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->job.table_numbers, (TableNumbers{5, 3}));
  EXPECT_TRUE(refused(read(ok + "table_numbers = [4, 4]\n"), ErrorCode::kInvalidInput,
                      at(6, "nc.table_numbers") + ": the two numbers are both 4; they must differ"));
  for (const char* bad : {"[1]", "[1, 2, 3]", "[0, 2]", "[1, 1000]", "[1.5, 2]", "3"}) {
    EXPECT_TRUE(refused(read(ok + "table_numbers = " + bad + "\n"), ErrorCode::kInvalidInput,
                        at(6, "nc.table_numbers") + ": expected two distinct whole numbers 1..999"))
        << bad;
  }
  EXPECT_TRUE(refused(read(ok + "table_number = 1\ntable_numbers = [1, 2]\n"), ErrorCode::kInvalidInput,
                      at(6, "nc.table_number") + ": give table_numbers = [A, B] alone"));
}

TEST_F(ServiceConfigTest, TheControlsXResolutionAndTheArchiveHeaderAreRead) {
  const std::string ok = "[gauge]\n" + kIntake + kNc;  // 5 lines
  auto d = read(ok);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->job.table_format.x_increments_per_mm, 10000.0) << "0.1 um unless told";
  auto c = read(ok + "int_incr_per_mm = 1000\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->job.table_format.x_increments_per_mm, 1000.0);
  EXPECT_EQ(c->job.table_format.x_decimals(), 3);
  EXPECT_FALSE(c->job.nc_archive_header) << "no archive header unless asked";
  auto h = read(ok + "archive_header = true\n");
  ASSERT_TRUE(h.ok()) << h.error().message;
  EXPECT_TRUE(h->job.nc_archive_header);
  for (const char* bad : {"0", "1.5", "2000000", "\"1000\""}) {
    auto r = read(ok + "int_incr_per_mm = " + bad + "\n");
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().message.find(at(6, "nc.int_incr_per_mm")), std::string::npos) << r.error().message;
  }
}

TEST_F(ServiceConfigTest, TheMainProgramTemplateIsReadWhenNamed) {
  dir_.write("main.mpf", "N10 {{program_name}}\nN20 EGON(X,\"FINE\",C,{{table_number}},0)\n{{infeed_blocks}}\nM30\n");
  auto c = read("[gauge]\n" + kIntake + kNc + "main_template = \"main.mpf\"\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->job.nc_main_template_name, (dir_.path() / "main.mpf").string());
  EXPECT_NE(c->job.nc_main_template.find("EGON"), std::string::npos);
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kNc + "main_template = \"absent.mpf\"\n"), ErrorCode::kNotFound,
                      at(6, "nc.main_template")));
}

TEST_F(ServiceConfigTest, AValueOutOfRangeSaysWhatIsAllowed) {
  const std::string ok = "[gauge]\n" + kIntake + kNc;  // 5 lines
  EXPECT_TRUE(refused(read(ok + "[compensation]\ngain = 3.0\n"), ErrorCode::kInvalidInput,
                      at(7, "compensation.gain") + ": 3 is out of range; allowed (0, 1]"));
  EXPECT_TRUE(refused(read(ok + "[compensation]\ngain = 0\n"), ErrorCode::kInvalidInput,
                      at(7, "compensation.gain") + ": 0 is out of range; allowed (0, 1]"));
  EXPECT_TRUE(refused(read("[gauge]\nrevolutions = 2\n" + kIntake + kNc), ErrorCode::kInvalidInput,
                      at(2, "gauge.revolutions") + ": 2 is out of range; allowed [3, 100]"));
  EXPECT_TRUE(refused(read(ok + "[analysis]\nbase_circle_center_deg = 361\n"), ErrorCode::kInvalidInput,
                      at(7, "analysis.base_circle_center_deg") + ": 361 is out of range; allowed [0, 360]"));
  EXPECT_TRUE(refused(read(ok + "table_number = 1000\n"), ErrorCode::kInvalidInput,
                      at(6, "nc.table_number") + ": 1000 is out of range; allowed [1, 998]"));
  EXPECT_TRUE(refused(read(ok + "x_min_mm = 5\nx_max_mm = 5\n"), ErrorCode::kInvalidInput,
                      at(7, "nc.x_max_mm") + ": must be above x_min_mm"));
  EXPECT_TRUE(refused(read(ok + "table = \"cubic\"\n"), ErrorCode::kInvalidInput,
                      at(6, "nc.table") + ": `cubic` is not one of auto, linear, spline, adaptive-linear, "
                                          "adaptive-spline"));
  EXPECT_TRUE(refused(read(ok + "[http]\nport = 65536\n"), ErrorCode::kInvalidInput,
                      at(7, "http.port") + ": 65536 is out of range; allowed [0, 65535]"));
  EXPECT_TRUE(refused(read(ok + "[plc]\nbase_address = 65500\n"), ErrorCode::kInvalidInput,
                      at(7, "plc.base_address") + ": 65500 is out of range; allowed [0, 65499]"));
  EXPECT_TRUE(refused(read(ok + "[plc]\npart_temperature = true\nbase_address = 65499\n"), ErrorCode::kInvalidInput,
                      at(8, "plc.base_address") + ": 65499 is out of range; allowed [0, 65498]"))
      << "the block is a word longer with the part temperature";
  EXPECT_TRUE(refused(read(ok + "[plc]\npoll_interval_ms = 5\n"), ErrorCode::kInvalidInput,
                      at(7, "plc.poll_interval_ms") + ": 5 is out of range; allowed [10, 10000]"));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + "plc_part_number = 0\n" + kNc), ErrorCode::kInvalidInput,
                      at(4, "part.plc_part_number") + ": 0 is out of range; allowed [1, 65535]"));
}

TEST_F(ServiceConfigTest, APartFileThatDoesNotExistIsNotFoundAtItsKey) {
  auto c = read("[gauge]\n[[part]]\nfile = \"parts/crank.toml\"\n" + kNc);
  EXPECT_TRUE(refused(
      c, ErrorCode::kNotFound,
      at(3, "part.file") + ": part file " + (dir_.path() / "parts" / "crank.toml").string() + ": no such file"));
}

TEST_F(ServiceConfigTest, AGaugeConfigOrTemplateThatDoesNotExistIsNotFoundAtItsKey) {
  EXPECT_TRUE(refused(read("[gauge]\nconfig = \"amp.toml\"\n" + kIntake + kNc), ErrorCode::kNotFound,
                      at(2, "gauge.config") + ": gauge config " + (dir_.path() / "amp.toml").string()));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + "[nc]\ntemplate = \"none.spf\"\n"), ErrorCode::kNotFound,
                      at(5, "nc.template") + ": NC template " + (dir_.path() / "none.spf").string()));
  // An error inside the gauge config names that file's line and key too.
  dir_.write("amp.toml", "[link]\nport = 0\n");
  EXPECT_TRUE(refused(read("[gauge]\nconfig = \"amp.toml\"\n" + kIntake + kNc), ErrorCode::kInvalidInput,
                      at(2, "gauge.config") + ": " + (dir_.path() / "amp.toml").string() + ":2: key `link.port`"));
}

TEST_F(ServiceConfigTest, APartConfiguredTwiceIsRefusedAtTheSecond) {
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kExhaust + kIntake + kNc), ErrorCode::kInvalidInput,
                      at(7, "part.file") + ": part intake_flat lobe 1 is configured twice"));
}

TEST_F(ServiceConfigTest, APlcPartNumberNamesOnePart) {
  const std::string text =
      "[gauge]\n" + kIntake + "plc_part_number = 7\n" + kExhaust + "plc_part_number = 7\n" + kNc + "[plc]\n";
  EXPECT_TRUE(refused(read(text), ErrorCode::kInvalidInput,
                      at(7, "part.plc_part_number") +
                          ": 7 already names part intake_flat, not exhaust_roller; give each part its own number"));
}

TEST_F(ServiceConfigTest, APlcWithoutNumberedPartsIsRefused) {
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kNc + "[plc]\n"), ErrorCode::kInvalidInput,
                      (dir_.path() / "svc.toml").string() + ": [plc] is set but no [[part]] has a plc_part_number"));
}

TEST_F(ServiceConfigTest, APlcLinkIsReadLikeAGaugeLink) {
  auto c = read("[gauge]\n" + kIntake + "plc_part_number = 3\n" + kNc +
                "[plc]\ntransport = \"rtu\"\ndevice = \"/dev/ttyS2\"\nbaud = 9600\nparity = \"E\"\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->plc->link.link.transport, ModbusTransport::kRtu);
  EXPECT_EQ(c->plc->link.link.device, "/dev/ttyS2");
  EXPECT_EQ(c->plc->link.link.baud, 9600);
  EXPECT_EQ(c->plc->link.link.parity, 'E');
  EXPECT_EQ(c->plc->poll_interval.count(), 100);
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + "plc_part_number = 3\n" + kNc + "[plc]\nbaud = 9600\n"),
                      ErrorCode::kInvalidInput, at(8, "plc.baud") + ": a serial setting in a TCP link"));
}

TEST_F(ServiceConfigTest, HttpTokensAreCheckedWhenRead) {
  const std::string ok = "[gauge]\n" + kIntake + kNc + "[http]\n";  // [http] on line 6
  write_secret("token", kStrongToken);
  EXPECT_TRUE(refused(read(ok + "token = \"" + kStrongToken + "\"\ntoken_file = \"token\"\n"), ErrorCode::kInvalidInput,
                      at(8, "http.token_file") + ": give token or token_file, not both"));
  write_secret("blank", " \r\n\n");
  EXPECT_TRUE(refused(read(ok + "token_file = \"blank\"\n"), ErrorCode::kInvalidInput,
                      at(7, "http.token_file") + ": the file is empty"));
  EXPECT_TRUE(refused(read(ok + "token_file = \"absent\"\n"), ErrorCode::kNotFound,
                      at(7, "http.token_file") + ": HTTP token file " + (dir_.path() / "absent").string()));
  auto readonly = read(ok + "port = 0\n");
  ASSERT_TRUE(readonly.ok()) << readonly.error().message;
  EXPECT_TRUE(readonly->http->token.empty());
  EXPECT_EQ(readonly->http->host, "127.0.0.1");
  EXPECT_EQ(readonly->http->port, 0);
  auto good = read(ok + "token_file = \"token\"\n");
  ASSERT_TRUE(good.ok()) << good.error().message;
  EXPECT_EQ(good->http->token, kStrongToken);
}

// The documented layout, root:gaugeloop 0640, and the owner-only 0600 are taken; any mode that
// lets another user read the token, or anyone but the owner write it, is refused at its key,
// saying what is wrong and the commands that fix it.
TEST_F(ServiceConfigTest, ATokenFileOthersCanReadOrWriteIsRefused) {
  const std::string ok = "[gauge]\n" + kIntake + kNc + "[http]\ntoken_file = \"token\"\n";  // line 7
  const std::string file = (dir_.path() / "token").string();
  const std::string fix = "run `chmod 0640 " + file + "; chown root:gaugeloop " + file + "`";
  for (mode_t mode : {0600, 0640, 0400, 0440}) {
    write_secret("token", kStrongToken, mode);
    auto c = read(ok);
    EXPECT_TRUE(c.ok()) << std::oct << mode << ": " << c.error().message;
  }
  const struct {
    mode_t mode;
    const char* wrong;
  } kRefused[] = {{0644, "can be read by any user (mode 0644)"},    {0604, "can be read by any user (mode 0604)"},
                  {0601, "gives any user access (mode 0601)"},      {0660, "can be written by its group (mode 0660)"},
                  {0602, "can be written by any user (mode 0602)"}, {0666, "can be written by any user (mode 0666)"}};
  for (const auto& r : kRefused) {
    write_secret("token", kStrongToken, r.mode);
    auto c = read(ok);
    EXPECT_TRUE(refused(c, at(7, "http.token_file") + ": HTTP token file " + file + " " + r.wrong))
        << std::oct << r.mode;
    EXPECT_TRUE(refused(c, fix)) << std::oct << r.mode;
  }
}

// Another account owning the file could replace the token with one it knows.
TEST_F(ServiceConfigTest, ATokenFileOwnedBySomeoneElseIsRefused) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to give the file to another user";
  const fs::path token = write_secret("token", kStrongToken, 0640);
  ASSERT_EQ(::chown(token.c_str(), 4242, 0), 0);
  auto c = read("[gauge]\n" + kIntake + kNc + "[http]\ntoken_file = \"token\"\n");
  EXPECT_TRUE(refused(c, at(7, "http.token_file") + ": HTTP token file " + token.string() +
                             " is owned by uid 4242, neither root nor the user this service runs as (uid 0)"));
  EXPECT_TRUE(refused(c, "chown root:gaugeloop " + token.string()));
}

// A link to the token, or a token in a directory any user can write, lets another account
// choose the token.
TEST_F(ServiceConfigTest, ATokenFileThroughALinkOrInAWorldWritableDirectoryIsRefused) {
  const fs::path token = write_secret("token", kStrongToken, 0640);
  fs::create_symlink(token, dir_.path() / "link");
  auto linked = read("[gauge]\n" + kIntake + kNc + "[http]\ntoken_file = \"link\"\n");
  EXPECT_TRUE(refused(linked, at(7, "http.token_file") + ": HTTP token file " + (dir_.path() / "link").string() +
                                  " is a symbolic link"));
  const fs::path open_dir = dir_.path() / "open";
  fs::create_directories(open_dir);
  fs::permissions(open_dir, fs::perms::all);  // 0777, no sticky bit
  fs::copy_file(token, open_dir / "token");
  fs::permissions(open_dir / "token", fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  auto open = read("[gauge]\n" + kIntake + kNc + "[http]\ntoken_file = \"open/token\"\n");
  EXPECT_TRUE(refused(open, "lies in a directory any user can write (" + open_dir.string() + ")"));
  fs::permissions(open_dir, fs::perms::sticky_bit, fs::perm_options::add);  // as /tmp: others cannot replace it
  auto sticky = read("[gauge]\n" + kIntake + kNc + "[http]\ntoken_file = \"open/token\"\n");
  EXPECT_TRUE(sticky.ok()) << sticky.error().message;
}

TEST_F(ServiceConfigTest, AnInlineTokenIsRefusedUnlessAllowed) {
  const std::string ok = "[gauge]\n" + kIntake + kNc + "[http]\n";  // [http] on line 6
  const std::string inline_token = "token = \"" + std::string(kStrongToken) + "\"\n";
  auto refused_inline = read(ok + inline_token);
  EXPECT_TRUE(refused(refused_inline, at(7, "http.token") + ": a token written in the config is refused: the config "
                                                            "is often readable by every user and copied around"));
  EXPECT_TRUE(refused(refused_inline, "`gaugeloop token new /etc/gaugeloop/token`"));
  EXPECT_TRUE(refused(refused_inline, "token_file = \"/etc/gaugeloop/token\""));
  auto allowed = read(ok + "allow_inline_token = true\n" + inline_token);
  ASSERT_TRUE(allowed.ok()) << allowed.error().message;
  EXPECT_EQ(allowed->http->token, kStrongToken);
  EXPECT_TRUE(refused(read(ok + "allow_inline_token = true\ntoken = \"aaaaaaaaaaaaaaaa\"\n"),
                      at(8, "http.token") + ": the token has 16 characters, fewer than 32: too easy to guess"));
}

// Length, variety and the estimate of bits each refuse what the others let through.
TEST_F(ServiceConfigTest, WeakTokensAreRefused) {
  const std::string ok = "[gauge]\n" + kIntake + kNc + "[http]\ntoken_file = \"token\"\n";  // line 7
  const std::string key = at(7, "http.token_file");
  const struct {
    std::string token;
    std::string why;
  } kWeak[] = {
      {"aaaaaaaaaaaaaaaa", ": the token has 16 characters, fewer than 32: too easy to guess"},
      {"s3cret-token", ": the token has 12 characters, fewer than 32"},
      {std::string(64, 'a'), ": the token uses only 1 different characters (at least 8): too easy to guess"},
      {"abababababababababababababababababababab", ": the token uses only 2 different characters"},
      // Letters and digits in one case only: 36 symbols, 5.2 bits a character, 124 bits.
      {"qwertyuiopasdfghjklzxcvbnm1234", ": the token has 30 characters"},
      {"0123456789012345678901234567890", ": the token has 31 characters"},
      // 33 digits: 3.3 bits each, 109 bits.
      {"012345678901234567890123456789012", ": the token holds about 109 bits, fewer than 128: too easy to guess"},
      {"0123456789abcdef0123456789abcd f", ": the token holds a blank or control character"},
  };
  for (const auto& w : kWeak) {
    write_secret("token", w.token);
    auto c = read(ok);
    EXPECT_TRUE(refused(c, key + w.why)) << w.token;
    EXPECT_TRUE(refused(c, "`gaugeloop token new FILE`")) << w.token;
  }
  // 32 hex characters: 128 bits, the least taken; 43 base64url characters: 258 bits.
  for (const char* strong : {"0f1e2d3c4b5a69788796a5b4c3d2e1f0", "q8V3nX_2rT-kL0pZ9mW4bY7cJ1dH6fG5sA3eU8iO2uQ"}) {
    write_secret("token", strong);
    auto c = read(ok);
    ASSERT_TRUE(c.ok()) << strong << ": " << c.error().message;
    EXPECT_EQ(c->http->token, strong);
  }
}

// HTTPS needs both files; each must be there, and the private key is a secret like the token.
TEST_F(ServiceConfigTest, TlsFilesAreReadRelativeToTheConfigAndTheKeyIsChecked) {
  const std::string ok = "[gauge]\n" + kIntake + kNc + "[http]\n";  // [http] on line 6
  dir_.write("tls/cert.pem", "-----BEGIN CERTIFICATE-----\n");
  write_secret("tls/key.pem", "-----BEGIN PRIVATE KEY-----\n", 0640);
  auto c = read(ok + "tls_cert = \"tls/cert.pem\"\ntls_key = \"tls/key.pem\"\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->http->tls_cert, dir_.path() / "tls" / "cert.pem");
  EXPECT_EQ(c->http->tls_key, dir_.path() / "tls" / "key.pem");
  auto plain = read(ok);
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  EXPECT_TRUE(plain->http->tls_cert.empty());
  EXPECT_TRUE(plain->http->tls_key.empty());

  EXPECT_TRUE(refused(read(ok + "tls_cert = \"tls/cert.pem\"\n"),
                      at(7, "http.tls_cert") + ": give both tls_cert and tls_key (PEM files) for HTTPS"));
  EXPECT_TRUE(refused(read(ok + "tls_key = \"tls/key.pem\"\n"), at(7, "http.tls_key") + ": give both"));
  EXPECT_TRUE(refused(read(ok + "tls_cert = \"tls/absent.pem\"\ntls_key = \"tls/key.pem\"\n"), ErrorCode::kNotFound,
                      at(7, "http.tls_cert") + ": TLS certificate"));
  EXPECT_TRUE(refused(read(ok + "tls_cert = \"tls/cert.pem\"\ntls_key = \"tls/absent.pem\"\n"), ErrorCode::kNotFound,
                      at(8, "http.tls_key") + ": TLS private key"));
  write_secret("tls/key.pem", "-----BEGIN PRIVATE KEY-----\n", 0644);
  EXPECT_TRUE(refused(read(ok + "tls_cert = \"tls/cert.pem\"\ntls_key = \"tls/key.pem\"\n"),
                      at(8, "http.tls_key") + ": TLS private key " + (dir_.path() / "tls" / "key.pem").string() +
                          " can be read by any user (mode 0644)"));
}

// A file where the NC directory or the database's directory should be: refused at load.
TEST_F(ServiceConfigTest, AnOutputPathThatCannotBeADirectoryIsRefusedAtItsKey) {
  dir_.write("afile", "not a directory\n");
  const std::string afile = (dir_.path() / "afile").string();
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kNc + "dir = \"afile/nc\"\n"), ErrorCode::kInvalidInput,
                      at(6, "nc.dir") + ": NC directory " + afile + "/nc: " + afile + " is not a directory"));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kNc + "[database]\npath = \"afile/runs.sqlite\"\n"),
                      ErrorCode::kInvalidInput,
                      at(7, "database.path") + ": database directory " + afile + ": " + afile + " is not a directory"));
}

// The top level's own mistakes are reported even when every table is fine.
TEST_F(ServiceConfigTest, ATopLevelErrorIsReportedAfterTheTablesAreRead) {
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kNc + "[compensation]\ngain = 2\n[extra]\n"),
                      ErrorCode::kInvalidInput, at(7, "compensation.gain")));
  EXPECT_TRUE(refused(read("[gauge]\n" + kIntake + kNc + "[extra]\n"), ErrorCode::kInvalidInput,
                      at(6, "extra") + ": unknown key"));
}

TEST_F(ServiceConfigTest, PartsAreFoundByNameOrPlcNumberAndLobe) {
  auto c = read("[gauge]\n" + kIntake + "plc_part_number = 5\n" + kExhaust + kNc + "[plc]\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  auto exhaust = find_part(*c, "exhaust_roller", 2);
  ASSERT_TRUE(exhaust.ok()) << exhaust.error().message;
  EXPECT_EQ((*exhaust)->file.part.name, "exhaust_roller");
  auto wrong_lobe = find_part(*c, "exhaust_roller", 1);
  ASSERT_FALSE(wrong_lobe.ok());
  EXPECT_EQ(wrong_lobe.error().code, ErrorCode::kNotFound);
  EXPECT_NE(
      wrong_lobe.error().message.find("part exhaust_roller lobe 1 is not in " + (dir_.path() / "svc.toml").string() +
                                      "; configured: intake_flat lobe 1, exhaust_roller lobe 2"),
      std::string::npos)
      << wrong_lobe.error().message;

  auto by_number = find_plc_part(*c, 5, 1);
  ASSERT_TRUE(by_number.ok()) << by_number.error().message;
  EXPECT_EQ((*by_number)->file.part.name, "intake_flat");
  auto unknown = find_plc_part(*c, 6, 1);
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code, ErrorCode::kNotFound);
  EXPECT_NE(unknown.error().message.find("PLC part number 6 lobe 1 is not in"), std::string::npos);
  EXPECT_NE(unknown.error().message.find("configured: 5 lobe 1 (intake_flat)"), std::string::npos)
      << unknown.error().message;

  const JobSettings job = job_for(*c, **exhaust);
  EXPECT_EQ(job.part.name, "exhaust_roller");
  EXPECT_EQ(job.nc_program, "CAM_EXHAUST_L2");
  EXPECT_EQ(job.design.lift_mm.size(), (*exhaust)->design.lift_mm.size());
  EXPECT_EQ(job.db_path, c->job.db_path);
  EXPECT_EQ(job.nc_dir, c->job.nc_dir);
}

// The query commands' --config reads only where the runs and NC programs are, as the service
// does, and nothing else: a token file it cannot read does not stop `runs list`.
TEST_F(ServiceConfigTest, TheDataPathsAloneAreReadForTheQueryCommands) {
  const fs::path config =
      dir_.write("etc/svc.toml", "[gauge]\n" + kIntake +
                                     "[nc]\ndir = \"../out/nc\"\n[database]\n"
                                     "path = \"/var/lib/x/runs-7.sqlite\"\n[http]\ntoken_file = \"absent\"\n");
  auto paths = read_service_data_paths(config);
  ASSERT_TRUE(paths.ok()) << paths.error().message;
  EXPECT_EQ(paths->db_path, fs::path("/var/lib/x/runs-7.sqlite"));
  EXPECT_EQ(paths->nc_dir, dir_.path() / "out" / "nc");
  auto defaults = read_service_data_paths(dir_.write("etc/bare.toml", "[gauge]\n"));
  ASSERT_TRUE(defaults.ok()) << defaults.error().message;
  EXPECT_EQ(defaults->db_path, dir_.path() / "etc" / "gaugeloop.sqlite");
  EXPECT_EQ(defaults->nc_dir, dir_.path() / "etc" / "nc");
  EXPECT_TRUE(refused(read_service_data_paths(dir_.write("etc/bad.toml", "[database]\npath = 7\n")),
                      (dir_.path() / "etc" / "bad.toml").string() + ":2: key `database.path`"));
  EXPECT_TRUE(refused(read_service_data_paths(dir_.path() / "absent.toml"), ErrorCode::kNotFound,
                      "service config " + (dir_.path() / "absent.toml").string() + ": no such file"));
}

}  // namespace
}  // namespace gaugeloop

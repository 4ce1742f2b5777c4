// The push of a crankpin ground C-X-Y: the Y table program beside the X table, written first
// for the version the X table then takes, and the main program coupling both. A real RunStore
// on disk and the real NC directory, with faults scripted by FailingNcFiles.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <optional>
#include <string>

#include "core/text_file.h"
#include "job/nc_push.h"
#include "job/pin_files.h"
#include "nc_out/main_program.h"
#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"
#include "storage/run_store.h"
#include "tests/support/failing_nc_files.h"
#include "tests/support/sample_runs.h"
#include "tests/support/store_test.h"
#include "tests/support/table_program.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

const std::string kSinumerik = std::string(GAUGELOOP_SOURCE_DIR) + "/examples/sinumerik/";
constexpr TableNumbers kXNumbers{1, 2};
constexpr TableNumbers kYNumbers{3, 4};

// A Y table program for `run` and `version` (the wheel height of a pin of throw `throw_mm`),
// rendered through `y_template` with its number alternating over kYNumbers.
Result<std::string> y_program_for(const std::string& y_template, std::int64_t run, int version, double throw_mm) {
  SampledPath p;
  p.c_step_deg = 0.01;
  constexpr double kRad = std::numbers::pi / 180.0;
  for (int k = 0; k < 36000; ++k) {
    const double c = k * 0.01 * kRad;
    p.x_mm.push_back(throw_mm * std::sin(c));
    p.dx_dc_mm_per_deg.push_back(throw_mm * std::cos(c) * kRad);
    p.d2x_dc2_mm_per_deg2.push_back(-throw_mm * std::sin(c) * kRad * kRad);
  }
  Result<CurveTable> table = write_linear_table(p, 1.0);
  if (!table) return table.error();
  std::map<std::string, std::string> values = {{"program_name", "CAM_TEST_Y"},
                                               {"part", "crankpin"},
                                               {"lobe", "1"},
                                               {"version", "test"},
                                               {"run_id", std::to_string(run)},
                                               {"origin", "run " + std::to_string(run)},
                                               {"created_utc", ""},
                                               {"correction_max_um", "0"},
                                               {"table_number", "3"}};
  TableProvenance provenance{run, version, kYNumbers};
  return render_table_program(y_template, "pin_y_table.spf", values, *table, provenance);
}

class PinFilesTest : public testing::StoreTest {
 protected:
  void SetUp() override {
    StoreTest::SetUp();
    if (HasFatalFailure()) return;
    fs::create_directories(dir_ / "nc");
    Result<std::int64_t> id =
        store_->insert_run(testing::sample_run("crankpin", 1, "grinder-1", "2026-12-01T08:00:00Z", 5.0));
    ASSERT_TRUE(id.ok()) << id.error().message;
    run_ = *id;
    Result<std::string> y = read_regular_file(kSinumerik + "pin_y_table.spf", "Y template");
    ASSERT_TRUE(y.ok()) << y.error().message;
    y_template_ = *y;
    Result<std::string> tmpl = read_regular_file(kSinumerik + "pin_main.mpf", "main template");
    ASSERT_TRUE(tmpl.ok()) << tmpl.error().message;
    main_.template_text = *tmpl;
    main_.template_name = "pin_main.mpf";
    main_.part = "crankpin";
    main_.lobe = 1;
    main_.created_utc = "2026-12-01T08:05:00Z";
    main_.y_program_name = "CAM_TEST_Y";
    main_.y_table_numbers = kYNumbers;
  }

  fs::path nc_file() const { return dir_ / "nc" / "CAM_TEST.SPF"; }
  fs::path y_file() const { return dir_ / "nc" / "CAM_TEST_Y.SPF"; }
  fs::path main_file() const { return dir_ / "nc" / "CAM_TEST_MAIN.MPF"; }

  // Pushes the X table (stroke 1 + version mm) and the Y table (throw 40 + version mm).
  Result<PushCompletion> push(NcFiles& files) {
    PushFacts facts;
    facts.run_id = run_;
    facts.reason = "run " + std::to_string(run_);
    PushOptions options;
    options.files = &files;
    options.main = main_;
    return push_pin_programs(
        *store_, nc_file(), facts,
        [this](int version) { return testing::program_for(run_, version, 1.0 + version, kXNumbers); },
        [this](int version) { return y_program_for(y_template_, run_, version, 40.0 + version); }, options);
  }

  std::string on_control(const fs::path& p) {
    Result<std::string> text = read_regular_file(p, "program");
    EXPECT_TRUE(text.ok()) << p;
    return text.ok() ? *text : std::string();
  }

  ParsedTable parsed(const fs::path& p) {
    Result<ParsedTable> t = parse_table_program(on_control(p), p.string());
    EXPECT_TRUE(t.ok()) << t.error().message;
    return t.ok() ? *t : ParsedTable{};
  }

  // The CTABDEF number the main program couples Y through.
  static int y_coupled(const std::string& main) {
    const std::string at = "EGON(Y,\"FINE\",C,";
    const std::size_t i = main.find(at);
    if (i == std::string::npos) return -1;
    return std::stoi(main.substr(i + at.size()));
  }

  std::int64_t run_ = 0;
  std::string y_template_;
  MainProgramSource main_;
};

TEST_F(PinFilesTest, TheYFileNamesTheXProgramsRunAndVersionAndAlternatesOverItsOwnNumbers) {
  EXPECT_EQ(y_table_program_path(nc_file()), y_file());
  testing::FailingNcFiles files;
  for (int version = 1; version <= 2; ++version) {
    Result<PushCompletion> r = push(files);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->table_version, version);
    const ParsedTable x = parsed(nc_file());
    const ParsedTable y = parsed(y_file());
    EXPECT_EQ(y.following_axis, "Y");
    EXPECT_EQ(y.header.at("run_id"), x.header.at("run_id")) << "version " << version;
    EXPECT_EQ(y.header.at("table_version"), x.header.at("table_version")) << "version " << version;
    EXPECT_EQ(y.header.at("table_version"), std::to_string(version));
    EXPECT_EQ(x.table_number, table_number_for_version(kXNumbers, version));
    EXPECT_EQ(y.table_number, table_number_for_version(kYNumbers, version)) << "version " << version;
    const std::string main = on_control(main_file());
    Result<int> x_coupled = coupled_table_number(main, main_file().string());
    ASSERT_TRUE(x_coupled.ok()) << x_coupled.error().message;
    EXPECT_EQ(*x_coupled, x.table_number) << main;
    EXPECT_EQ(y_coupled(main), y.table_number) << main;
    EXPECT_NE(main.find("\nN15 CAM_TEST_Y "), std::string::npos) << "the main program loads the Y table:\n" << main;
  }
  EXPECT_NE(parsed(y_file()).table_number, 3) << "the second push went to the other Y number";
}

TEST_F(PinFilesTest, AYTemplateThatDefinesAnXTableIsRefusedBeforeAnythingIsWritten) {
  testing::FailingNcFiles files;
  const std::size_t at = y_template_.find("CTABDEF(Y,");
  ASSERT_NE(at, std::string::npos);
  y_template_.replace(at, std::string("CTABDEF(Y,").size(), "CTABDEF(X,");
  Result<PushCompletion> r = push(files);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(r.error().message.find("CTABDEF(Y,C,...)"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(y_file().string()), std::string::npos) << r.error().message;
  EXPECT_FALSE(fs::exists(y_file()));
  EXPECT_FALSE(fs::exists(nc_file()));
  EXPECT_FALSE(fs::exists(main_file()));
  for (testing::FailingNcFiles::Op op : files.calls) {
    EXPECT_NE(op, testing::FailingNcFiles::Op::kWrite) << "nothing was written";
  }
  Result<std::optional<NcPush>> last = store_->last_push(nc_file().string());
  ASSERT_TRUE(last.ok());
  EXPECT_FALSE(last->has_value());
}

// The Y table is written first, to the number of the new version; the X table's write then
// fails, and the push puts the previous Y file back: the control holds the previous X and Y
// tables, a matched pair, and a main program that couples them.
TEST_F(PinFilesTest, AnXTableNotWrittenLeavesTheControlGrindingThePreviousMatchedPair) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());  // version 1: X table 1, Y table 3
  const std::string x_before = on_control(nc_file());
  const std::string main_before = on_control(main_file());
  ASSERT_EQ(y_coupled(main_before), 3);

  files.fail_writes_ending_with = "CAM_TEST.SPF";
  Result<PushCompletion> second = push(files);
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.error().code, ErrorCode::kIo);
  EXPECT_NE(second.error().message.find("not pushed"), std::string::npos) << second.error().message;

  const ParsedTable y = parsed(y_file());
  EXPECT_EQ(y.header.at("table_version"), "1") << "the Y file of the previous version is back";
  EXPECT_EQ(y.table_number, 3);
  EXPECT_EQ(on_control(nc_file()), x_before) << "the X program is the previous one";
  EXPECT_EQ(on_control(main_file()), main_before) << "the main program is the previous one";
  EXPECT_EQ(y_coupled(on_control(main_file())), 3) << "it still couples the previous Y number";
  Result<std::optional<NcPush>> last = store_->last_push(nc_file().string());
  ASSERT_TRUE(last.ok());
  ASSERT_TRUE(last->has_value());
  EXPECT_EQ((**last).table_version, 1) << "the history is the previous one";
  Result<std::vector<PushIntent>> open = store_->open_push_intents();
  ASSERT_TRUE(open.ok());
  EXPECT_TRUE(open->empty());

  // The next push takes version 2 again and completes the pair.
  files.fail_writes_ending_with.clear();
  Result<PushCompletion> third = push(files);
  ASSERT_TRUE(third.ok()) << third.error().message;
  EXPECT_EQ(third->table_version, 2);
  EXPECT_EQ(parsed(nc_file()).header.at("table_version"), "2");
  EXPECT_EQ(y_coupled(on_control(main_file())), 4);
}

TEST_F(PinFilesTest, AYTableNotWrittenChangesNothingElse) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());
  const std::string x_before = on_control(nc_file());
  const std::string y_before = on_control(y_file());
  const std::string main_before = on_control(main_file());

  files.fail_writes_ending_with = "_Y.SPF";
  Result<PushCompletion> second = push(files);
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.error().code, ErrorCode::kIo);
  EXPECT_NE(second.error().message.find("not written"), std::string::npos) << second.error().message;
  EXPECT_NE(second.error().message.find(y_file().string()), std::string::npos) << second.error().message;
  EXPECT_EQ(on_control(y_file()), y_before);
  EXPECT_EQ(on_control(nc_file()), x_before);
  EXPECT_EQ(on_control(main_file()), main_before);
  Result<std::optional<NcPush>> last = store_->last_push(nc_file().string());
  ASSERT_TRUE(last.ok());
  ASSERT_TRUE(last->has_value());
  EXPECT_EQ((**last).table_version, 1);
  Result<std::vector<PushIntent>> open = store_->open_push_intents();
  ASSERT_TRUE(open.ok());
  EXPECT_TRUE(open->empty());
}

// A share that changes what it is given: the write succeeds, the read gives other text.
class RewritingNcFiles final : public NcFiles {
 public:
  Result<DirectoryLock> lock_directory(const fs::path& dir) override { return real_nc_files().lock_directory(dir); }
  bool is_directory(const fs::path& dir) override { return real_nc_files().is_directory(dir); }
  Result<std::optional<std::string>> read_program(const fs::path& path) override {
    Result<std::optional<std::string>> r = real_nc_files().read_program(path);
    if (!r || !*r) return r;
    std::string text = **r;
    for (char& c : text) {
      if (c == '\n') c = ' ';  // line ends lost, as some shares do
    }
    return std::optional<std::string>(text);
  }
  Status write_program(const fs::path& path, std::string_view contents, const AtomicWriteObserver& observer) override {
    return real_nc_files().write_program(path, contents, observer);
  }
  Result<int> remove_leftovers(const fs::path& path) override { return real_nc_files().remove_leftovers(path); }
};

TEST_F(PinFilesTest, WriteProgramBesideRefusesWhatReadsBackDifferently) {
  RewritingNcFiles files;
  Status s = write_program_beside(y_file(), "N10 G0 Y0\nM17\n", "Y table", files);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
  EXPECT_NE(s.error().message.find("Y table read back differs"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find(y_file().string()), std::string::npos) << s.error().message;

  testing::FailingNcFiles plain;
  ASSERT_TRUE(write_program_beside(y_file(), "N10 G0 Y0\nM17\n", "Y table", plain).ok());
  EXPECT_EQ(on_control(y_file()), "N10 G0 Y0\nM17\n");
}

}  // namespace
}  // namespace gaugeloop

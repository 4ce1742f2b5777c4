// The AQDEF (.dfq) export: every field written read back by a reader of our own, a file
// written by hand from the public format description reproduced byte for byte, and the
// refusals.
#include <gtest/gtest.h>

#include <clocale>
#include <cmath>
#include <fstream>
#include <limits>
#include <locale>
#include <sstream>
#include <string>
#include <vector>

#include "core/number_text.h"
#include "report/dfq.h"
#include "storage/run_store.h"
#include "tests/support/dfq_reader.h"

namespace gaugeloop {
namespace {

using testing::DfqFile;
using testing::read_dfq;

Characteristic characteristic(std::string key, std::string unit, double value, std::optional<double> lower,
                              std::optional<double> upper) {
  return single_characteristic(std::move(key), std::move(unit), value, Limits{lower, upper});
}

RunCharacteristics run(std::int64_t id, std::string started_utc, std::string serial, std::string operator_name,
                       std::vector<Characteristic> characteristics, std::string part = "camshaft-A1", int lobe = 2) {
  RunCharacteristics r;
  r.run.id = id;
  r.run.started_utc = std::move(started_utc);
  r.run.machine = "grinder-1";
  r.run.part = std::move(part);
  r.run.lobe = lobe;
  r.run.serial = std::move(serial);
  r.run.operator_name = std::move(operator_name);
  r.characteristics = std::move(characteristics);
  return r;
}

// The runs the hand-written fixture describes.
std::vector<RunCharacteristics> hand_written_runs() {
  return {
      run(11, "2026-11-22T08:15:02Z", "S-1001", "J. Smith",
          {characteristic("lift_error.nose", "um", 3.214, -10.0, 10.0),
           characteristic("base_circle_runout", "um", 1.052, std::nullopt, 5.0)}),
      run(12, "2026-11-22T09:40:37Z", "S-1002", "J. Smith",
          {characteristic("lift_error.nose", "um", -2.5, -10.0, 10.0),
           characteristic("base_circle_runout", "um", 0.98, std::nullopt, 5.0)}),
      run(14, "2026-11-23T07:05:09Z", "S-1003", "K. Weber",
          {characteristic("lift_error.nose", "um", 4.0, -10.0, 10.0),
           characteristic("base_circle_runout", "um", 1.5, std::nullopt, 5.0)}),
  };
}

std::string read_fixture(const std::string& name) {
  std::ifstream in(std::string(GAUGELOOP_SOURCE_DIR) + "/tests/report/data/" + name, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

DfqFile written_and_read(const std::vector<RunCharacteristics>& runs, const DfqOptions& options = {}) {
  Result<std::string> text = write_dfq(runs, options);
  EXPECT_TRUE(text.ok()) << (text.ok() ? "" : text.error().message);
  if (!text) return {};
  Result<DfqFile> file = read_dfq(*text);
  EXPECT_TRUE(file.ok()) << (file.ok() ? "" : file.error().message);
  return file.ok() ? *file : DfqFile{};
}

TEST(DfqHandWritten, ReaderReadsTheFixtureWrittenFromTheFormatDescription) {
  Result<DfqFile> file = read_dfq(read_fixture("hand_written.dfq"));
  ASSERT_TRUE(file.ok()) << file.error().message;
  EXPECT_EQ(file->total_characteristics, 2);
  ASSERT_EQ(file->parts.size(), 1u);
  EXPECT_EQ(file->parts[0].fields.at("K1001"), "camshaft-A1");
  EXPECT_EQ(file->parts[0].fields.at("K1002"), "lobe 2");
  EXPECT_EQ(file->parts[0].fields.at("K1081"), "grinder-1");
  EXPECT_EQ(file->parts[0].fields.at("K1086"), "cam grinding");
  ASSERT_EQ(file->characteristics.size(), 2u);
  const auto& lift = file->characteristics[0];
  EXPECT_EQ(lift.fields.at("K2001"), "lift_error.nose");
  EXPECT_EQ(lift.fields.at("K2002"), "Lift error, nose");
  EXPECT_EQ(lift.fields.at("K2022"), "3");
  EXPECT_EQ(lift.fields.at("K2101"), "0.000");
  EXPECT_EQ(lift.fields.at("K2110"), "-10.000");
  EXPECT_EQ(lift.fields.at("K2111"), "10.000");
  EXPECT_EQ(lift.fields.at("K2120"), "0");
  EXPECT_EQ(lift.fields.at("K2121"), "0");
  EXPECT_EQ(lift.fields.at("K2142"), "um");
  const auto& runout = file->characteristics[1];
  EXPECT_EQ(runout.fields.at("K2001"), "base_circle_runout");
  EXPECT_EQ(runout.fields.at("K2110"), "0.000");
  EXPECT_EQ(runout.fields.at("K2120"), "1");
  ASSERT_EQ(lift.values.size(), 3u);
  ASSERT_EQ(runout.values.size(), 3u);
  EXPECT_EQ(lift.values[1].fields.at("K0001"), "-2.500");
  EXPECT_EQ(lift.values[1].fields.at("K0002"), "0");
  EXPECT_EQ(lift.values[1].fields.at("K0004"), "22.11.2026/09:40:37");
  EXPECT_EQ(lift.values[1].fields.at("K0006"), "12");
  EXPECT_EQ(lift.values[1].fields.at("K0008"), "J. Smith");
  EXPECT_EQ(lift.values[1].fields.at("K0010"), "grinder-1");
  EXPECT_EQ(lift.values[1].fields.at("K0014"), "S-1002");
  EXPECT_EQ(runout.values[2].fields.at("K0001"), "1.500");
  EXPECT_EQ(runout.values[2].fields.at("K0008"), "K. Weber");
}

TEST(DfqHandWritten, WriterReproducesTheFixtureByteForByte) {
  Result<std::string> text = write_dfq(hand_written_runs(), DfqOptions{});
  ASSERT_TRUE(text.ok()) << text.error().message;
  EXPECT_EQ(*text, read_fixture("hand_written.dfq"));
}

TEST(DfqHandWritten, RunsInAnyOrderAreWrittenOldestFirst) {
  std::vector<RunCharacteristics> runs = hand_written_runs();
  std::swap(runs[0], runs[2]);
  Result<std::string> text = write_dfq(runs, DfqOptions{});
  ASSERT_TRUE(text.ok()) << text.error().message;
  EXPECT_EQ(*text, read_fixture("hand_written.dfq"));
}

TEST(DfqRoundTrip, EveryFieldWrittenReadsBack) {
  std::vector<RunCharacteristics> runs = {
      run(3, "2026-11-22T02:34:44Z", "CS-77", "Ana",
          {characteristic("lift_error", "um", -7.25, -15.0, 15.0),
           characteristic("velocity_error.opening_flank", "mm/deg", 0.0001234, -0.0005, 0.0005),
           characteristic("acceleration_error", "mm/deg^2", -0.00000123, std::nullopt, std::nullopt),
           characteristic("phase", "deg", 0.1234, -0.25, 0.25), characteristic("roundness", "um", 0.8, 0.1, 2.0)}),
      run(4, "2026-11-22T03:00:00Z", "", "",
          {characteristic("phase", "deg", -0.3, -0.2, 0.2), characteristic("lift_error", "um", 1.0, -15.0, 15.0)}),
  };
  const DfqFile file = written_and_read(runs);
  ASSERT_EQ(file.total_characteristics, 5);
  ASSERT_EQ(file.parts.size(), 1u);
  EXPECT_EQ(file.parts[0].fields.at("K1001"), "camshaft-A1");
  EXPECT_EQ(file.parts[0].fields.at("K1002"), "lobe 2");
  EXPECT_EQ(file.parts[0].fields.at("K1081"), "grinder-1");
  EXPECT_EQ(file.parts[0].fields.at("K1086"), "cam grinding");
  EXPECT_EQ(file.parts[0].fields.size(), 4u);
  ASSERT_EQ(file.characteristics.size(), 5u);

  // The first run's order; each characteristic with exactly the fields it should carry.
  const std::vector<std::string> keys = {"lift_error", "velocity_error.opening_flank", "acceleration_error", "phase",
                                         "roundness"};
  const std::vector<std::string> decimals = {"3", "6", "8", "4", "3"};
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const auto& c = file.characteristics[i];
    SCOPED_TRACE(keys[i]);
    EXPECT_EQ(c.fields.at("K2001"), keys[i]);
    EXPECT_EQ(c.fields.at("K2002"), characteristic_title(keys[i]));
    EXPECT_EQ(c.fields.at("K2022"), decimals[i]);
    EXPECT_EQ(c.fields.at("K2101"), format_fixed(0.0, std::stoi(decimals[i])));
    EXPECT_EQ(c.fields.at("K2120"), "0");
    EXPECT_EQ(c.fields.at("K2121"), "0");
  }
  EXPECT_EQ(file.characteristics[0].fields.at("K2142"), "um");
  EXPECT_EQ(file.characteristics[1].fields.at("K2142"), "mm/deg");
  EXPECT_EQ(file.characteristics[2].fields.at("K2142"), "mm/deg^2");
  EXPECT_EQ(file.characteristics[3].fields.at("K2142"), "deg");
  EXPECT_EQ(file.characteristics[1].fields.at("K2110"), "-0.000500");
  EXPECT_EQ(file.characteristics[1].fields.at("K2111"), "0.000500");
  // No limits: neither K2110 nor K2111 (an acceleration error may have none).
  EXPECT_EQ(file.characteristics[2].fields.count("K2110"), 0u);
  EXPECT_EQ(file.characteristics[2].fields.count("K2111"), 0u);
  // The newest run's limits for phase; a given lower limit of roundness is a tolerance.
  EXPECT_EQ(file.characteristics[3].fields.at("K2110"), "-0.2000");
  EXPECT_EQ(file.characteristics[3].fields.at("K2111"), "0.2000");
  EXPECT_EQ(file.characteristics[4].fields.at("K2110"), "0.100");

  // Values: run 3 has all five, run 4 only lift_error and phase; its other three are
  // placeholders, so the n-th values of every characteristic are the n-th run's.
  for (const auto& c : file.characteristics) ASSERT_EQ(c.values.size(), 2u) << c.fields.at("K2001");
  for (std::size_t i : {1u, 2u, 4u}) {
    const auto& placeholder = file.characteristics[i].values[1].fields;
    EXPECT_EQ(placeholder.at("K0002"), "255");
    EXPECT_EQ(placeholder.at("K0001"), format_fixed(0.0, std::stoi(decimals[i])));
    EXPECT_EQ(placeholder.at("K0006"), "4");
    EXPECT_EQ(placeholder.at("K0004"), "22.11.2026/03:00:00");
  }
  EXPECT_EQ(file.characteristics[0].values[1].fields.at("K0002"), "0");
  EXPECT_EQ(file.characteristics[0].values[1].fields.at("K0001"), "1.000");
  const auto& first = file.characteristics[1].values[0].fields;
  EXPECT_EQ(first.at("K0001"), "0.000123");
  EXPECT_EQ(first.at("K0002"), "0");
  EXPECT_EQ(first.at("K0004"), "22.11.2026/02:34:44");
  EXPECT_EQ(first.at("K0006"), "3");
  EXPECT_EQ(first.at("K0008"), "Ana");
  EXPECT_EQ(first.at("K0010"), "grinder-1");
  EXPECT_EQ(first.at("K0014"), "CS-77");
  EXPECT_EQ(first.size(), 7u);
  EXPECT_EQ(file.characteristics[2].values[0].fields.at("K0001"), "-0.00000123");
  const auto& second = file.characteristics[3].values[1].fields;
  EXPECT_EQ(second.at("K0001"), "-0.3000");
  EXPECT_EQ(second.at("K0004"), "22.11.2026/03:00:00");
  EXPECT_EQ(second.at("K0006"), "4");
  // No serial or operator given: no K0014 or K0008 rather than an empty field.
  EXPECT_EQ(second.count("K0008"), 0u);
  EXPECT_EQ(second.count("K0014"), 0u);
  EXPECT_EQ(second.size(), 5u);
}

TEST(DfqRoundTrip, HarmonicsOnlyWhenAskedWithANaturalLowerBoundary) {
  LobeAnalysis analysis;
  for (std::size_t k = 0; k < analysis.harmonic_amplitude_um.size(); ++k)
    analysis.harmonic_amplitude_um[k] = 0.5 * static_cast<double>(k);
  RunCharacteristics r = run(5, "2026-11-22T02:34:44Z", "S", "O", {characteristic("phase", "deg", 0.01, -0.2, 0.2)});
  const std::vector<Characteristic> harmonics = harmonic_characteristics(analysis, 4);
  ASSERT_EQ(harmonics.size(), 4u);
  r.characteristics.insert(r.characteristics.end(), harmonics.begin(), harmonics.end());

  EXPECT_EQ(written_and_read({r}).total_characteristics, 1) << "harmonics are left out unless asked";

  DfqOptions options;
  options.harmonics = 3;
  const DfqFile file = written_and_read({r}, options);
  ASSERT_EQ(file.total_characteristics, 4);
  for (int k = 1; k <= 3; ++k) {
    const auto& c = file.characteristics[static_cast<std::size_t>(k)];
    SCOPED_TRACE(k);
    EXPECT_EQ(c.fields.at("K2001"), "harmonic." + std::to_string(k));
    EXPECT_EQ(c.fields.at("K2002"), "Lift error, harmonic " + std::to_string(k));
    EXPECT_EQ(c.fields.at("K2142"), "um");
    EXPECT_EQ(c.fields.at("K2110"), "0.000");
    EXPECT_EQ(c.fields.at("K2120"), "1");
    EXPECT_EQ(c.fields.count("K2111"), 0u);
    ASSERT_EQ(c.values.size(), 1u);
    EXPECT_EQ(c.values[0].fields.at("K0001"), format_fixed(0.5 * k, 3));
  }
}

TEST(DfqRoundTrip, OnePartBlockPerPartAndLobeNumberedAcrossTheFile) {
  std::vector<RunCharacteristics> runs = {
      run(1, "2026-11-22T01:00:00Z", "SH-9", "O", {characteristic("phase", "deg", 0.1, -0.2, 0.2)}, "shaft-X", 1),
      run(2, "2026-11-22T01:05:00Z", "SH-9", "O",
          {characteristic("phase", "deg", 0.05, -0.2, 0.2), characteristic("roundness", "um", 0.4, std::nullopt, 2.0)},
          "shaft-X", 2),
      run(3, "2026-11-22T02:00:00Z", "SH-10", "O", {characteristic("phase", "deg", 0.12, -0.2, 0.2)}, "shaft-X", 1),
  };
  runs[1].run.machine = "grinder-2";
  const DfqFile file = written_and_read(runs);
  ASSERT_EQ(file.total_characteristics, 3);
  ASSERT_EQ(file.parts.size(), 2u);
  EXPECT_EQ(file.parts[0].fields.at("K1002"), "lobe 1");
  EXPECT_EQ(file.parts[1].fields.at("K1002"), "lobe 2");
  EXPECT_EQ(file.parts[1].fields.at("K1081"), "grinder-2");
  EXPECT_EQ(file.parts[0].characteristics, std::vector<int>({1}));
  EXPECT_EQ(file.parts[1].characteristics, std::vector<int>({2, 3}));
  ASSERT_EQ(file.characteristics[0].values.size(), 2u);
  EXPECT_EQ(file.characteristics[0].values[1].fields.at("K0014"), "SH-10");
  ASSERT_EQ(file.characteristics[1].values.size(), 1u) << "a block's values are its own runs'";
  EXPECT_EQ(file.characteristics[1].values[0].fields.at("K0010"), "grinder-2");
  EXPECT_EQ(file.characteristics[2].fields.at("K2120"), "1") << "roundness has a natural lower boundary";
}

TEST(DfqRoundTrip, APinsBlockSaysPinAndTitlesItsRoundnessAsThePins) {
  const std::vector<RunCharacteristics> runs = {
      run(5, "2026-11-22T02:34:44Z", "", "",
          {characteristic("roundness", "um", 3.5, std::nullopt, 4.0),
           characteristic("diameter_error", "um", 0.15, -8.0, 8.0),
           characteristic("stroke_error", "um", -0.01, -25.0, 25.0),
           characteristic("index_error", "deg", 0.002, -0.03, 0.03)}),
  };
  const DfqFile file = written_and_read(runs);
  ASSERT_EQ(file.parts.size(), 1u);
  EXPECT_EQ(file.parts[0].fields.at("K1002"), "pin 2");
  ASSERT_EQ(file.characteristics.size(), 4u);
  EXPECT_EQ(file.characteristics[0].fields.at("K2001"), "roundness");
  EXPECT_EQ(file.characteristics[0].fields.at("K2002"), "Pin roundness");
  EXPECT_EQ(file.characteristics[1].fields.at("K2002"), "Pin diameter error");
}

// The title of an error characteristic names the curve it judged, as every other view of the run
// does, when the block's runs agree on it; the history that does not say leaves it out.
TEST(DfqRoundTrip, AnErrorCharacteristicsTitleNamesTheCurveItsRunsJudged) {
  auto lobe_runs = [](std::optional<LiftErrorReference> first, std::optional<LiftErrorReference> second) {
    std::vector<RunCharacteristics> runs = {
        run(1, "2026-11-22T02:34:44Z", "", "",
            {characteristic("lift_error", "um", 4.0, -12.0, 12.0),
             characteristic("lift_error.closing_ramp", "um", -3.0, -8.0, 8.0),
             characteristic("phase", "deg", 0.01, -0.1, 0.1)}),
        run(2, "2026-11-22T02:40:00Z", "", "",
            {characteristic("lift_error", "um", 5.0, -12.0, 12.0),
             characteristic("lift_error.closing_ramp", "um", -2.0, -8.0, 8.0),
             characteristic("phase", "deg", 0.02, -0.1, 0.1)}),
    };
    runs[0].run.lift_error_reference = first;
    runs[1].run.lift_error_reference = second;
    return runs;
  };
  DfqFile file = written_and_read(lobe_runs(LiftErrorReference::kBestFit, LiftErrorReference::kBestFit));
  ASSERT_EQ(file.characteristics.size(), 3u);
  EXPECT_EQ(file.characteristics[0].fields.at("K2002"), "Lift error, whole turn (after best-fit phase)");
  EXPECT_EQ(file.characteristics[1].fields.at("K2002"), "Lift error, closing ramp (after best-fit phase)");
  EXPECT_EQ(file.characteristics[2].fields.at("K2002"), "Phase (timing) error") << "not an error curve's figure";
  file = written_and_read(lobe_runs(LiftErrorReference::kNominal, LiftErrorReference::kNominal));
  EXPECT_EQ(file.characteristics[0].fields.at("K2002"), "Lift error, whole turn (at nominal timing)");
  file = written_and_read(lobe_runs(LiftErrorReference::kNominal, LiftErrorReference::kBestFit));
  EXPECT_EQ(file.characteristics[0].fields.at("K2002"), "Lift error, whole turn") << "the runs disagree";
  file = written_and_read(lobe_runs(std::nullopt, std::nullopt));
  EXPECT_EQ(file.characteristics[0].fields.at("K2002"), "Lift error, whole turn") << "the history does not say";

  std::vector<RunCharacteristics> pin = {run(5, "2026-11-22T02:34:44Z", "", "",
                                             {characteristic("roundness", "um", 3.5, std::nullopt, 4.0),
                                              characteristic("diameter_error", "um", 0.15, -8.0, 8.0)})};
  pin[0].run.lift_error_reference = LiftErrorReference::kBestFit;
  file = written_and_read(pin);
  EXPECT_EQ(file.characteristics[0].fields.at("K2002"), "Pin roundness (less LS circle)");
}

TEST(DfqRoundTrip, OneBlockOfRunsFromTwoMachinesHasNoPartMachine) {
  std::vector<RunCharacteristics> runs = hand_written_runs();
  runs[1].run.machine = "grinder-2";
  const DfqFile file = written_and_read(runs);
  ASSERT_EQ(file.parts.size(), 1u);
  EXPECT_EQ(file.parts[0].fields.count("K1081"), 0u);
  EXPECT_EQ(file.characteristics[0].values[1].fields.at("K0010"), "grinder-2");
}

TEST(DfqRoundTrip, AGermanLocaleStillWritesDecimalPoints) {
  const std::string plain = *write_dfq(hand_written_runs(), DfqOptions{});
  const char* previous = std::setlocale(LC_NUMERIC, nullptr);
  const std::string saved = previous != nullptr ? previous : "C";
  if (std::setlocale(LC_NUMERIC, "de_DE.UTF-8") == nullptr) {
    FAIL() << "de_DE.UTF-8 locale not installed; scripts/install-deps.sh generates it";
  }
  const std::locale saved_global = std::locale::global(std::locale("de_DE.UTF-8"));
  Result<std::string> german = write_dfq(hand_written_runs(), DfqOptions{});
  std::locale::global(saved_global);
  std::setlocale(LC_NUMERIC, saved.c_str());
  ASSERT_TRUE(german.ok());
  EXPECT_EQ(*german, plain);
}

void expect_refused(const std::vector<RunCharacteristics>& runs, const std::string& says,
                    const DfqOptions& options = {}) {
  Result<std::string> text = write_dfq(runs, options);
  ASSERT_FALSE(text.ok());
  EXPECT_EQ(text.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(text.error().message.find(says), std::string::npos) << text.error().message;
}

TEST(DfqRefusals, ALimitThatIsNotFinite) {
  std::vector<RunCharacteristics> runs = hand_written_runs();
  runs[1].characteristics[0].limits.upper = std::numeric_limits<double>::infinity();
  expect_refused(runs, "run 12, characteristic lift_error.nose: a limit is not finite");
}

TEST(DfqRefusals, AValueThatIsNotFinite) {
  std::vector<RunCharacteristics> runs = hand_written_runs();
  runs[2].characteristics[1].value = std::nan("");
  expect_refused(runs, "run 14, characteristic base_circle_runout: the value is not finite");
}

// German plants' names: UTF-8 in gaugeloop, Windows-1252 in the file, as Q-DAS tools read it.
TEST(DfqText, UmlautsAndTheEuroSignAreWrittenInWindows1252) {
  std::vector<RunCharacteristics> runs = hand_written_runs();
  runs[0].run.operator_name = "J\xC3\xBCrgen M\xC3\xBCller";  // Jürgen Müller
  runs[0].run.serial = "\xC3\x9C-42 \xE2\x82\xAC \xC3\x9F";   // Ü-42 € ß
  Result<std::string> text = write_dfq(runs, {});
  ASSERT_TRUE(text.ok()) << text.error().message;
  EXPECT_NE(text->find("K0008/1 J\xFCrgen M\xFCller\r\n"), std::string::npos);
  EXPECT_NE(text->find("K0014/1 \xDC-42 \x80 \xDF\r\n"), std::string::npos);
  EXPECT_EQ(text->find("\xC3"), std::string::npos) << "no UTF-8 left in the file";
}

TEST(DfqRefusals, TextWindows1252CannotCarry) {
  std::vector<RunCharacteristics> runs = hand_written_runs();
  runs[0].run.operator_name = "Li \xE7\x8E\x8B";  // a CJK character
  expect_refused(runs,
                 "run 11: operator (K0008) \"Li \xE7\x8E\x8B\" has \"\xE7\x8E\x8B\", which Windows-1252 has no "
                 "byte for at character 4");
  runs[0].run.operator_name = "Anna";
  runs[0].run.serial = "S\tT";
  expect_refused(runs, "run 11: serial (K0014) \"S\tT\" has a control character at character 2");
  runs[0].run.serial = "S\xFF";  // Latin-1, not UTF-8
  expect_refused(runs, "has a byte that is not UTF-8 at character 2");
}

TEST(DfqRefusals, ASerialLongerThanK0014Takes) {
  std::vector<RunCharacteristics> runs = hand_written_runs();
  runs[0].run.serial = std::string(41, 'S');
  expect_refused(runs, "longer than the 40 characters");
}

TEST(DfqRefusals, RunsWithoutCharacteristics) {
  std::vector<RunCharacteristics> runs = hand_written_runs();
  for (RunCharacteristics& r : runs) r.characteristics.clear();
  expect_refused(runs, "no characteristics recorded for part camshaft-A1 lobe 2");
}

TEST(DfqRefusals, NoRunsAndHarmonicsOutOfRange) {
  expect_refused({}, "no runs to export");
  DfqOptions options;
  options.harmonics = 31;
  expect_refused(hand_written_runs(), "harmonics 31 is out of range", options);
}

TEST(DfqRefusals, OneKeyWithTwoUnits) {
  std::vector<RunCharacteristics> runs = hand_written_runs();
  runs[2].characteristics[0].unit = "mm";
  expect_refused(runs, "run 14, characteristic lift_error.nose: unit \"mm\" where older runs have \"um\"");
}

TEST(DfqReader, RefusesMalformedLinesNamingTheLine) {
  const std::string good = read_fixture("hand_written.dfq");
  auto refused = [](const std::string& text, const std::string& says) {
    Result<DfqFile> file = read_dfq(text);
    ASSERT_FALSE(file.ok()) << "read: " << text.substr(0, 80);
    EXPECT_NE(file.error().message.find(says), std::string::npos) << file.error().message;
  };
  refused("K0100 1\nK1001/1 p\r\n", "line 1: line ends in LF without CR");
  refused("K0100 1\r\nK1001/1 p\r\nK2001/2 x\r\n", "line 3: K2001/2: characteristic number out of sequence");
  refused("K0100 1\r\nK1001/1 p\r\nK2001/1 x\r\nK0002/1 0\r\n", "line 4: K0002 before the K0001 of its value");
  refused(
      "K0100 1\r\nK1001/1 p\r\nK2001/1 x\r\n1.5\x0f"
      "0\r\n",
      "line 4: not a K-field line");
  refused("K0100 1\r\nK1001/1 p\r\nK2001/1 x\r\nK2001/1 y\r\n", "line 4: K2001 given twice");
  refused("K0100 2\r\nK1001/1 p\r\nK2001/1 x\r\n", "K0100 says 2 characteristics, the file describes 1");
  refused("K0100 1\r\nK1001/0 p\r\n", "line 2: /0 (all characteristics) is not read");
  refused("K01X0 1\r\n", "line 1: the K-field number is not 4 digits");
  // The fixture with one line broken in the middle.
  std::string broken = good;
  broken.replace(broken.find("K2022/2 3"), 9, "K2022/2");
  refused(broken, "line 17: no space after the K-field");
}

}  // namespace
}  // namespace gaugeloop

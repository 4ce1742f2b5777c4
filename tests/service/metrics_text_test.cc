// The /metrics text: valid Prometheus exposition, names in base units, the build's identity,
// and a log that does not grow with every scrape. The exposition is checked by a strict reader
// of the text format written here: promtool comes only with Debian's prometheus server
// package, which is not among the project's dependencies.
#include "service/metrics_text.h"
// Before <httplib.h>: http_api.h brings Eigen, and httplib's <resolv.h> defines a macro `_res`
// that Eigen uses as a parameter name.
#include "service/http_api.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "storage/run_store.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

// Reads Prometheus text exposition format 0.0.4 strictly and returns "" or the first fault.
// Beyond the format: every family has one HELP and one TYPE before its first sample, a
// family's samples are not interleaved with another's, counters end in _total, and no name
// carries a unit other than a base unit (seconds, bytes, meters).
std::string exposition_fault(const std::string& text) {
  static const std::regex kName("[a-zA-Z_:][a-zA-Z0-9_:]*");
  static const std::regex kLabelName("[a-zA-Z_][a-zA-Z0-9_]*");
  static const std::regex kUnit(".*_(um|mm|ms|us|ns|minutes|hours|kb|mb|percent|deg|degrees)(_total)?");
  static const std::set<std::string> kTypes = {"counter", "gauge", "histogram", "summary", "untyped"};
  if (!text.empty() && text.back() != '\n') return "the text does not end with a newline";
  std::map<std::string, std::string> type_of;
  std::set<std::string> helped;
  std::set<std::string> finished;  // families whose samples ended
  std::set<std::string> series;
  std::string current;  // the family of the last sample
  std::istringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    const std::string where = "line " + std::to_string(n) + " \"" + line + "\": ";
    if (line.empty()) continue;
    if (line.starts_with("# HELP ") || line.starts_with("# TYPE ")) {
      const std::string rest = line.substr(7);
      const std::size_t space = rest.find(' ');
      if (space == std::string::npos) return where + "no text after the name";
      const std::string name = rest.substr(0, space);
      const std::string value = rest.substr(space + 1);
      if (!std::regex_match(name, kName)) return where + "not a metric name";
      if (series.contains(name) || finished.contains(name) || current == name) {
        return where + "HELP or TYPE after the family's samples";
      }
      if (line[2] == 'H') {
        if (!helped.insert(name).second) return where + "a second HELP";
        if (value.empty()) return where + "an empty HELP";
      } else {
        if (type_of.contains(name)) return where + "a second TYPE";
        if (!kTypes.contains(value)) return where + "unknown type " + value;
        type_of[name] = value;
      }
      continue;
    }
    if (line[0] == '#') continue;  // a comment
    std::size_t i = 0;
    while (i < line.size() && line[i] != '{' && line[i] != ' ') ++i;
    const std::string name = line.substr(0, i);
    if (!std::regex_match(name, kName)) return where + "not a metric name";
    std::map<std::string, std::string> labels;
    if (i < line.size() && line[i] == '{') {
      ++i;
      while (i < line.size() && line[i] != '}') {
        std::size_t eq = line.find('=', i);
        if (eq == std::string::npos) return where + "a label without '='";
        const std::string label = line.substr(i, eq - i);
        if (!std::regex_match(label, kLabelName) || label.starts_with("__")) return where + "bad label name " + label;
        i = eq + 1;
        if (i >= line.size() || line[i] != '"') return where + "a label value not in quotes";
        ++i;
        std::string value;
        for (;;) {
          if (i >= line.size()) return where + "an unterminated label value";
          const char c = line[i++];
          if (c == '"') break;
          if (c == '\\') {
            if (i >= line.size()) return where + "a backslash at the end";
            const char e = line[i++];
            if (e != '\\' && e != '"' && e != 'n') return where + "an unknown escape \\" + std::string(1, e);
            value += e == 'n' ? '\n' : e;
          } else {
            value += c;
          }
        }
        if (!labels.emplace(label, value).second) return where + "label " + label + " twice";
        if (i < line.size() && line[i] == ',') ++i;
      }
      if (i >= line.size()) return where + "no closing brace";
      ++i;
    }
    if (i >= line.size() || line[i] != ' ') return where + "no space before the value";
    const std::string value = line.substr(i + 1);
    if (value.empty() || value.find(' ') != std::string::npos) return where + "not exactly one value";
    if (value != "+Inf" && value != "-Inf" && value != "NaN") {
      char* end = nullptr;
      std::strtod(value.c_str(), &end);
      if (end == nullptr || *end != '\0') return where + "value " + value + " is not a number";
    }
    if (!type_of.contains(name)) return where + "a sample before its family's TYPE";
    if (!helped.contains(name)) return where + "a sample before its family's HELP";
    if (finished.contains(name)) return where + "the family's samples are split";
    if (name != current) {
      if (!current.empty()) finished.insert(current);
      current = name;
    }
    if (type_of[name] == "counter" && !name.ends_with("_total")) return where + "a counter not ending in _total";
    if (std::regex_match(name, kUnit)) return where + "a unit that is not a base unit";
    std::string key = name;
    for (const auto& [k, v] : labels) key += "|" + k + "=" + v;
    if (!series.insert(key).second) return where + "a series given twice";
  }
  return {};
}

TEST(ExpositionReader, RefusesWhatPrometheusWouldRefuseOrWeDoNotAllow) {
  const std::string family = "# HELP a_total A.\n# TYPE a_total counter\n";
  EXPECT_EQ(exposition_fault(family + "a_total 1\n"), "");
  EXPECT_EQ(exposition_fault(family + "a_total{x=\"1\",y=\"q\\\"\\\\\\n\"} 1\n"), "");
  EXPECT_NE(exposition_fault("a_total 1\n"), "") << "no TYPE";
  EXPECT_NE(exposition_fault(family + "# TYPE a_total counter\na_total 1\n"), "") << "two TYPEs";
  EXPECT_NE(exposition_fault(family + "a_total 1\na_total 2\n"), "") << "one series twice";
  EXPECT_NE(exposition_fault(family + "a_total{x=\"1\"} 1\na_total{x=\"1\"} 2\n"), "") << "one series twice";
  EXPECT_NE(exposition_fault(family + "a_total{x=\"1} 1\n"), "") << "unterminated";
  EXPECT_NE(exposition_fault(family + "a_total{x=\"\\t\"} 1\n"), "") << "an escape the format lacks";
  EXPECT_NE(exposition_fault(family + "a_total one\n"), "") << "not a number";
  EXPECT_NE(exposition_fault(family + "a_total 1"), "") << "no final newline";
  EXPECT_NE(exposition_fault("# HELP 1a A.\n# TYPE 1a gauge\n1a 1\n"), "") << "a name starting with a digit";
  EXPECT_NE(exposition_fault("# HELP a A.\n# TYPE a counter\na 1\n"), "") << "a counter without _total";
  EXPECT_NE(exposition_fault("# HELP e_um E.\n# TYPE e_um gauge\ne_um 1\n"), "") << "micrometres";
  EXPECT_NE(exposition_fault(family + "# HELP b B.\n# TYPE b gauge\na_total{x=\"1\"} 1\nb 1\na_total{x=\"2\"} 1\n"), "")
      << "a family split by another";
  EXPECT_NE(exposition_fault(family + "a_total 1\n# HELP a_total again\n"), "") << "HELP after samples";
}

// A database of two machines, two lobes and a part, a pending table and every event kind.
void fill(const fs::path& db) {
  Result<RunStore> store = RunStore::open(db);
  ASSERT_TRUE(store.ok()) << store.error().message;
  std::vector<std::int64_t> ids;
  for (const RunRecord& r : {testing::sample_run("intake", 1, "g1", "2020-11-22T07:00:00Z", 3.0),
                             testing::sample_run("intake", 1, "g1", "2020-11-22T08:00:00Z", 4.0),
                             testing::sample_run("intake", 2, "g1", "2020-11-22T08:30:00Z", 31.0),
                             testing::sample_run("intake", 1, "g\"2\\\n", "2020-11-22T09:00:00Z", 6.5)}) {
    Result<std::int64_t> id = store->insert_run(r);
    ASSERT_TRUE(id.ok()) << id.error().message;
    ids.push_back(*id);
  }
  ASSERT_TRUE(store->record_nc_file(ids[1], "/nc/CAM_INTAKE_L1.SPF").ok());
  ASSERT_TRUE(store->record_event(testing::sample_refusal_event()).ok());
  PendingTable t;
  t.run_id = ids[2];
  t.nc_file = "/nc/CAM_INTAKE_L2.SPF";
  t.program_text = "N10 G1 C0 X0\n";
  ASSERT_TRUE(store->add_pending(t).ok());
}

using testing::has;

TEST(MetricsText, TheDatabaseSeriesAreValidAndInBaseUnits) {
  testing::TempDir dir;
  const fs::path db = dir / "runs.sqlite";
  fill(db);
  Result<RunStore> store = RunStore::open(db);
  ASSERT_TRUE(store.ok());
  std::string text;
  ASSERT_TRUE(append_database_metrics(*store, text).ok());
  append_database_up(true, text);
  append_build_info(text);
  EXPECT_EQ(exposition_fault(text), "") << text;
  for (const std::string& line : std::vector<std::string>{
           "gaugeloop_runs_stored{status=\"measured\"} 3\n",
           "gaugeloop_runs_stored{status=\"pushed\"} 1\n",
           "gaugeloop_events_stored{kind=\"refusal\"} 1\n",
           "gaugeloop_events_stored{kind=\"fault\"} 0\n",
           "gaugeloop_pending_tables 1\n",
           "# TYPE gaugeloop_last_run_max_abs_error_meters gauge\n",
           "gaugeloop_last_run_max_abs_error_meters{machine=\"g1\",part=\"intake\",lobe=\"1\"} 4e-06\n",
           "gaugeloop_last_run_max_abs_error_meters{machine=\"g1\",part=\"intake\",lobe=\"2\"} 3.1e-05\n",
           "gaugeloop_last_run_max_abs_error_meters{machine=\"g\\\"2\\\\\\n\",part=\"intake\",lobe=\"1\"} 6.5e-06\n",
           "gaugeloop_last_run_started_timestamp_seconds{machine=\"g1\",part=\"intake\",lobe=\"2\"} 1606033800\n",
           "gaugeloop_database_up 1\n",
           "gaugeloop_build_info{version=\"" GAUGELOOP_VERSION "\"} 1\n",
       }) {
    EXPECT_TRUE(has(text, line)) << "missing: " << line << "in:\n" << text;
  }
  EXPECT_FALSE(has(text, "_um")) << text;
}

// Log lines written while a test runs, at info and above.
class LogCapture {
 public:
  LogCapture() : previous_(spdlog::default_logger()) {
    auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(lines_);
    sink->set_pattern("%l %v");
    auto logger = std::make_shared<spdlog::logger>("capture", sink);
    logger->set_level(spdlog::level::info);
    logger->flush_on(spdlog::level::info);
    spdlog::set_default_logger(logger);
  }
  ~LogCapture() { spdlog::set_default_logger(previous_); }
  LogCapture(const LogCapture&) = delete;
  LogCapture& operator=(const LogCapture&) = delete;

  // The lines captured since the last call.
  std::vector<std::string> take() {
    std::vector<std::string> out;
    std::istringstream in(lines_.str());
    for (std::string line; std::getline(in, line);) out.push_back(line);
    lines_.str("");
    return out;
  }

 private:
  std::shared_ptr<spdlog::logger> previous_;
  std::ostringstream lines_;
};

class MetricsEndpoint : public ::testing::Test {
 protected:
  void SetUp() override {
    HttpSettings settings;
    settings.host = "127.0.0.1";
    settings.port = 0;
    Result<std::unique_ptr<HttpApi>> api = HttpApi::start(settings, db(), {}, {});
    ASSERT_TRUE(api.ok()) << api.error().message;
    api_ = std::move(*api);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", api_->port());
  }
  void TearDown() override {
    if (api_) api_->stop();
  }

  fs::path db() const { return dir_ / "runs.sqlite"; }

  // Three scrapes; the body of the last.
  std::string scrape_three_times() {
    std::string body;
    for (int i = 0; i < 3; ++i) {
      httplib::Result r = client_->Get("/metrics");
      EXPECT_TRUE(r);
      if (!r) return {};
      EXPECT_EQ(r->status, 200) << r->body;
      body = r->body;
    }
    return body;
  }

  testing::TempDir dir_;
  std::unique_ptr<HttpApi> api_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(MetricsEndpoint, BeforeTheFirstRunScrapesSayDownAndLogNothing) {
  LogCapture log;
  const std::string body = scrape_three_times();
  EXPECT_TRUE(has(body, "gaugeloop_database_up 0\n")) << body;
  EXPECT_TRUE(has(body, "gaugeloop_build_info{version=")) << body;
  EXPECT_EQ(exposition_fault(body), "") << body;
  EXPECT_EQ(log.take(), std::vector<std::string>{}) << "a missing database is normal before the first run";
}

TEST_F(MetricsEndpoint, AnUnreadableDatabaseIsLoggedOnceAndItsRecoveryOnce) {
  LogCapture log;
  std::ofstream(db()) << "this is not a database, and long enough to have a header of one: " << std::string(200, 'x');
  EXPECT_TRUE(has(scrape_three_times(), "gaugeloop_database_up 0\n"));
  const std::vector<std::string> failed = log.take();
  ASSERT_EQ(failed.size(), 1u) << "one warning for three scrapes";
  EXPECT_TRUE(failed[0].starts_with("warning ")) << failed[0];
  EXPECT_TRUE(has(failed[0], db().string())) << failed[0];

  fs::remove(db());
  fill(db());
  const std::string body = scrape_three_times();
  EXPECT_TRUE(has(body, "gaugeloop_database_up 1\n")) << body;
  EXPECT_TRUE(has(body, "gaugeloop_runs_stored{status=\"pushed\"} 1\n")) << body;
  EXPECT_EQ(exposition_fault(body), "") << body;
  const std::vector<std::string> recovered = log.take();
  ASSERT_EQ(recovered.size(), 1u) << "one line for the recovery";
  EXPECT_TRUE(recovered[0].starts_with("info ")) << recovered[0];
}

}  // namespace
}  // namespace gaugeloop

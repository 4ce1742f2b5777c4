// The HTTP API as a client sees it: a real server on a loopback port over a database filled
// through RunStore, read with httplib's client; the token, the hooks and every kind of bad request.
#include "service/http_api.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/number_text.h"
#include "job/measure_job.h"
#include "service/service.h"
#include "storage/run_store.h"
#include "tests/support/cli.h"
#include "tests/support/raw_http.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"

// Last: httplib brings <resolv.h>, whose `res` macro breaks Eigen's headers.
#include <httplib.h>

#include "tests/support/http_answer.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using testing::has;

RunRecord record(const std::string& part, int lobe, const std::string& machine, const std::string& started,
                 double max_um) {
  RunRecord r = testing::sample_run(part, lobe, machine, started, max_um);
  r.settings.clear();  // a run stored without its settings: the API shows a null hash
  return r;
}

const char* const kProgramV1 = "; CAM_INTAKE_L1 version 1\r\nCTABDEF(1,1)\r\nC0 X0\r\nCTABEND\r\n";
const char* const kProgramV2 = "; CAM_INTAKE_L1 version 2\r\nCTABDEF(1,1)\r\nC0 X0.0010\r\nCTABEND\r\n";

// What the fake hooks were called with, and what they answer.
struct HookLog {
  std::mutex mutex;
  std::vector<std::string> calls;
  void add(std::string call) {
    std::lock_guard lock(mutex);
    calls.push_back(std::move(call));
  }
  std::vector<std::string> all() {
    std::lock_guard lock(mutex);
    return calls;
  }
};

class HttpApiTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = tmp_.path(); }
  void TearDown() override { api_.reset(); }

  fs::path db() const { return dir_ / "gaugeloop.sqlite"; }

  // Runs 1, 2: intake lobe 1 on g1 over two days (1 pushed twice: versions 1 and 2); 3: lobe 2;
  // 4: lobe 1 on g2. One refusal, one fault, one pending table.
  void fill() {
    Result<RunStore> store = RunStore::open(db());
    ASSERT_TRUE(store.ok()) << store.error().message;
    ids_.push_back(*store->insert_run(record("intake", 1, "g1", "2020-11-20T08:00:00Z", 12.0)));
    ids_.push_back(*store->insert_run(record("intake", 1, "g1", "2020-11-21T08:00:00Z", 4.0)));
    ids_.push_back(*store->insert_run(record("intake", 2, "g1", "2020-11-21T09:00:00Z", 30.0)));
    ids_.push_back(*store->insert_run(record("intake", 1, "g2", "2020-11-22T08:00:00Z", 6.0)));
    NcPush push;
    push.nc_file = "/nc/CAM_INTAKE_L1.SPF";
    push.table.interpolation = "CSPLINE";
    push.table.block_count = 47;
    push.table.command_error_um = 0.497;
    ASSERT_TRUE(store->record_push(ids_[0], push, kProgramV1).ok());
    push.reason = "rollback to version 1 by anna";
    ASSERT_TRUE(store->record_push(ids_[0], push, kProgramV2).ok());
    PendingTable pending;
    pending.run_id = ids_[1];
    pending.nc_file = "/nc/CAM_INTAKE_L1.SPF";
    pending.program_text = "; pending";
    pending.verdict = PendingVerdict::kHold;
    pending.reason = "correction changes by 60 um";
    Result<std::int64_t> p = store->add_pending(pending);
    ASSERT_TRUE(p.ok()) << p.error().message;
    pending_id_ = *p;
    EventRecord e = testing::sample_refusal_event();
    ASSERT_TRUE(store->record_event(e).ok());
    e.at_utc = "2020-11-22T07:00:00Z";
    e.kind = EventKind::kFault;
    e.code = "gauge timeout";
    e.message = "gauge 127.0.0.1:1502 stopped answering";
    ASSERT_TRUE(store->record_event(e).ok());
  }

  void start(const std::string& token = "", HttpWrites writes = {}, HttpStatus status = {}) {
    HttpSettings settings;
    settings.port = 0;
    settings.token = token;
    Result<std::unique_ptr<HttpApi>> api = HttpApi::start(settings, db(), std::move(writes), std::move(status));
    ASSERT_TRUE(api.ok()) << api.error().message;
    api_ = std::move(*api);
    ASSERT_GT(api_->port(), 0);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", api_->port());
  }

  // Hooks that log their arguments and answer {"ok": true}.
  HttpWrites logging_writes() {
    HttpWrites w;
    w.trigger_measure = [this](const std::string& part, int lobe, const std::string& note, const std::string& serial,
                               const std::string& operator_name,
                               std::optional<double> part_temperature_c) -> Result<json> {
      log_.add("measure " + part + " " + std::to_string(lobe) + " " + note +
               (serial.empty() ? "" : " serial=" + serial) +
               (operator_name.empty() ? "" : " operator=" + operator_name) +
               (part_temperature_c ? " part_temperature_c=" + format_fixed(*part_temperature_c, 2) : ""));
      return json{{"queued", true}};
    };
    w.approve = [this](std::int64_t id, const std::string& by, const std::string& note) -> Result<json> {
      log_.add("approve " + std::to_string(id) + " " + by + " " + note);
      return json{{"approved", id}};
    };
    w.rollback = [this](const std::string& program, int version, const std::string& by) -> Result<json> {
      log_.add("rollback " + program + " " + std::to_string(version) + " " + by);
      return json{{"version", version + 1}};
    };
    return w;
  }

  using Answer = testing::HttpAnswer;
  static Answer answer_of(const httplib::Result& r) { return testing::answer_of(r); }

  Answer get(const std::string& path) { return answer_of(client_->Get(path)); }

  Answer post(const std::string& path, const std::string& body, const std::string& token = "") {
    httplib::Headers headers;
    if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
    return answer_of(client_->Post(path, headers, body, "application/json"));
  }

  std::vector<std::int64_t> listed(const std::string& query) {
    Answer a = get("/api/runs" + query);
    EXPECT_EQ(a.status, 200) << a.body;
    std::vector<std::int64_t> out;
    for (const json& run : a.j) out.push_back(run["id"].get<std::int64_t>());
    return out;
  }

  // The error message of a JSON error answer, after checking its status.
  static std::string error_of(const Answer& a, int status) {
    EXPECT_EQ(a.status, status) << a.body;
    EXPECT_EQ(a.content_type, "application/json") << a.body;
    EXPECT_TRUE(a.j.is_object() && a.j.contains("error") && a.j["error"].is_string()) << a.body;
    return a.j.is_object() ? a.j.value("error", std::string()) : std::string();
  }

  testing::TempDir tmp_;  // before everything that lives in it
  fs::path dir_;
  std::vector<std::int64_t> ids_;
  std::int64_t pending_id_ = 0;
  HookLog log_;
  std::unique_ptr<HttpApi> api_;
  std::unique_ptr<httplib::Client> client_;
};

using Ids = std::vector<std::int64_t>;

TEST_F(HttpApiTest, HealthMergesTheServiceStateAndSaysWhetherTheDatabaseIsThere) {
  fill();
  HttpStatus status;
  status.health = [] { return json{{"state", "idle"}, {"config", "/etc/gaugeloop.toml"}}; };
  start("", {}, status);
  Answer a = get("/api/health");
  ASSERT_EQ(a.status, 200) << a.body;
  EXPECT_EQ(a.j["state"], "idle");
  EXPECT_EQ(a.j["config"], "/etc/gaugeloop.toml");
  EXPECT_EQ(a.j["database"]["available"], true);
  EXPECT_EQ(a.j["database"]["path"], db().string());
  EXPECT_TRUE(has(a.j["writes"].get<std::string>(), "disabled")) << a.body;
}

TEST_F(HttpApiTest, HealthIgnoresItsQueryAndIsAlways200) {
  start();
  for (const char* query : {"?x=1", "?t=1700000000&t=2", "?lobe=abc"}) {
    Answer a = get(std::string("/api/health") + query);
    EXPECT_EQ(a.status, 200) << query << ": " << a.body;
    EXPECT_TRUE(a.j.contains("version")) << a.body;
  }
}

TEST_F(HttpApiTest, RunsFilterByPartLobeMachineTimeAndStatusLikeTheCli) {
  fill();
  start();
  EXPECT_EQ(listed(""), (Ids{ids_[3], ids_[2], ids_[1], ids_[0]}));
  EXPECT_EQ(listed("?part=intake&lobe=1"), (Ids{ids_[3], ids_[1], ids_[0]}));
  EXPECT_EQ(listed("?machine=g2"), (Ids{ids_[3]}));
  EXPECT_EQ(listed("?status=pushed"), (Ids{ids_[0]}));
  EXPECT_EQ(listed("?since=2020-11-21&until=2020-11-21"), (Ids{ids_[2], ids_[1]}));
  EXPECT_EQ(listed("?since=2020-11-21T08:30"), (Ids{ids_[3], ids_[2]}));
  EXPECT_EQ(listed("?limit=1"), (Ids{ids_[3]}));
  EXPECT_EQ(listed("?part=exhaust"), Ids{});
  Answer a = get("/api/runs?lobe=2");
  ASSERT_EQ(a.j.size(), 1u) << a.body;
  EXPECT_EQ(a.j[0]["max_abs_error_um"], 30.0);
  EXPECT_EQ(a.j[0]["phase_error_deg"], 0.25);
  EXPECT_TRUE(a.j[0]["settings_hash"].is_null());
}

TEST_F(HttpApiTest, RunsFilterBySerialExactlyAndShowSerialAndOperatorOrNull) {
  fill();
  Result<RunStore> store = RunStore::open(db());
  ASSERT_TRUE(store.ok()) << store.error().message;
  RunRecord marked = record("intake", 1, "g1", "2020-11-23T08:00:00Z", 5.0);
  marked.serial = "CS 0042/7";
  marked.operator_name = "anna";
  const std::int64_t id = *store->insert_run(marked);
  marked.serial = "CS 0042/70";
  marked.started_utc = marked.finished_utc = "2020-11-23T09:00:00Z";
  ASSERT_TRUE(store->insert_run(marked).ok());
  start();
  Answer a = get("/api/runs?serial=CS%200042%2F7");
  ASSERT_EQ(a.status, 200) << a.body;
  ASSERT_EQ(a.j.size(), 1u) << a.body;
  EXPECT_EQ(a.j[0]["id"], id);
  EXPECT_EQ(a.j[0]["serial"], "CS 0042/7");
  EXPECT_EQ(a.j[0]["operator"], "anna");
  EXPECT_EQ(listed("?serial=cs%200042%2F7"), Ids{}) << "exact: case counts";
  Answer old = get("/api/runs/" + std::to_string(ids_[0]));
  ASSERT_EQ(old.status, 200) << old.body;
  EXPECT_TRUE(old.j.contains("serial") && old.j["serial"].is_null()) << old.body;
  EXPECT_TRUE(old.j.contains("operator") && old.j["operator"].is_null()) << old.body;
}

TEST_F(HttpApiTest, MeasurePassesSerialAndOperatorAndRefusesBadOnesWith400) {
  start("t", logging_writes());
  Answer ok = post("/api/measure", R"({"part": "intake", "lobe": 1, "serial": "CS-0042", "operator": "anna"})", "t");
  ASSERT_EQ(ok.status, 200) << ok.body;
  EXPECT_EQ(post("/api/measure", R"({"part": "intake", "lobe": 1, "serial": "", "operator": null})", "t").status, 200);
  EXPECT_EQ(log_.all(),
            (std::vector<std::string>{"measure intake 1  serial=CS-0042 operator=anna", "measure intake 1 "}));

  const std::string long_serial = std::string(65, '7');
  EXPECT_TRUE(has(
      error_of(post("/api/measure", R"({"part": "intake", "lobe": 1, "serial": ")" + long_serial + R"("})", "t"), 400),
      "`serial` is 65 characters long; at most 64"));
  EXPECT_TRUE(
      has(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1, "operator": "anna\nbert"})", "t"), 400),
          "`operator` has a control character"));
  EXPECT_TRUE(has(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1, "serial": 42})", "t"), 400),
                  "`serial` must be a string, not number"));
  EXPECT_EQ(log_.all().size(), 2u) << "a refused request queues no run";
}

// The part's temperature, deg C, given with the request: passed on rounded to 0.1; missing or
// null is not given; a value out of range, not a number, is a 400 naming the field, no run.
TEST_F(HttpApiTest, MeasurePassesThePartTemperatureAndRefusesABadOneWith400) {
  start("t", logging_writes());
  ASSERT_EQ(post("/api/measure", R"({"part": "intake", "lobe": 1, "part_temperature_c": 21.43})", "t").status, 200);
  ASSERT_EQ(post("/api/measure", R"({"part": "intake", "lobe": 1, "part_temperature_c": -5})", "t").status, 200);
  ASSERT_EQ(post("/api/measure", R"({"part": "intake", "lobe": 1, "part_temperature_c": null})", "t").status, 200);
  EXPECT_EQ(log_.all(), (std::vector<std::string>{"measure intake 1  part_temperature_c=21.40",
                                                  "measure intake 1  part_temperature_c=-5.00", "measure intake 1 "}));
  EXPECT_TRUE(
      has(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1, "part_temperature_c": 150.1})", "t"), 400),
          "`part_temperature_c` 150.1: not a part temperature"));
  EXPECT_TRUE(
      has(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1, "part_temperature_c": -40.5})", "t"), 400),
          "-40.0 to 150.0"));
  EXPECT_TRUE(
      has(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1, "part_temperature_c": "21,4"})", "t"), 400),
          "`part_temperature_c` must be a number, not \"21,4\""));
  EXPECT_EQ(log_.all().size(), 3u) << "a refused request queues no run";
}

TEST_F(HttpApiTest, GearRunsListFilterAndShowWithTheirTraces) {
  ASSERT_NO_FATAL_FAILURE(fill());
  {
    Result<RunStore> store = RunStore::open(db());
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (const auto& [started, worst] :
         {std::pair{"2020-11-20T10:00:00Z", 12.5}, std::pair{"2020-11-21T10:00:00Z", 2.5}}) {
      GearRunRecord g;
      g.started_utc = started;
      g.machine = "gear-grinder-2";
      g.part = "gear_71";
      g.source = "flank probe tcp:10.0.0.7:502";
      g.nc_file = "/nc/GEAR_71.SPF";
      g.required_class = 5;
      g.total_tolerance_um = 8.6;
      g.verdict = worst <= 8.6 ? Verdict::kIn : Verdict::kOut;
      g.tolerance_class = worst <= 8.6 ? 2 : 7;
      g.total_max_um = worst;
      g.total_mean_um = worst;
      GearTraceRecord t;
      t.gap = 1;
      t.flank = "left";
      t.total_um = worst;
      t.tolerance_class = g.tolerance_class;
      t.z_mm = {-1.0, 0.0, 1.0};
      t.deviation_um = {-worst / 2, 0.0, worst / 2};
      g.traces = {t};
      if (worst > 8.6) {
        // The first gear's profile at the face's middle, judged against F_alphaT as well.
        GearProfileRecord p;
        p.gap = 1;
        p.flank = "right";
        p.total_um = 3.5;
        p.tolerance_class = 4;
        p.roll_mm = {10.0, 12.0, 14.0};
        p.deviation_um = {-1.75, 0.0, 1.75};
        g.profiles = {p};
        g.profile_tolerance_um = 8.4;
      }
      ASSERT_TRUE(store->insert_gear_run(g).ok());
    }
  }
  start();
  Answer all = get("/api/gear-runs");
  ASSERT_EQ(all.status, 200) << all.body;
  ASSERT_EQ(all.j.size(), 2u) << all.body;
  EXPECT_EQ(all.j[0]["id"], 2);  // newest first
  EXPECT_FALSE(all.j[0].contains("traces"));
  EXPECT_TRUE(all.j[0]["serial"].is_null());
  Answer out = get("/api/gear-runs?verdict=out&part=gear_71");
  ASSERT_EQ(out.status, 200) << out.body;
  ASSERT_EQ(out.j.size(), 1u);
  EXPECT_EQ(out.j[0]["total_max_um"], 12.5);
  EXPECT_EQ(get("/api/gear-runs?since=2020-11-21").j.size(), 1u);
  EXPECT_TRUE(has(error_of(get("/api/gear-runs?verdict=maybe"), 400), "`verdict` must be in or out or not_judged"));
  EXPECT_TRUE(has(error_of(get("/api/gear-runs?lobe=1"), 400), "lobe"));
  Answer one = get("/api/gear-runs/1");
  ASSERT_EQ(one.status, 200) << one.body;
  ASSERT_EQ(one.j["traces"].size(), 1u);
  EXPECT_EQ(one.j["traces"][0]["flank"], "left");
  EXPECT_EQ(one.j["traces"][0]["deviation_um"][2], 6.25);
  EXPECT_EQ(one.j["total_tolerance_um"], 8.6);
  ASSERT_EQ(one.j["profiles"].size(), 1u) << one.body;
  EXPECT_EQ(one.j["profiles"][0]["flank"], "right");
  EXPECT_EQ(one.j["profiles"][0]["roll_mm"][2], 14.0);
  EXPECT_EQ(one.j["profile"]["total_max_um"], 3.5);
  EXPECT_EQ(one.j["profile_tolerance_um"], 8.4);
  Answer two = get("/api/gear-runs/2");
  ASSERT_EQ(two.status, 200) << two.body;
  EXPECT_TRUE(two.j["profiles"].empty());
  EXPECT_TRUE(two.j["profile"].is_null());
  EXPECT_TRUE(two.j["profile_tolerance_um"].is_null());
  EXPECT_TRUE(has(error_of(get("/api/gear-runs/9"), 404), "GET /api/gear-runs lists the ids"));
  Answer pdf = get("/api/gear-runs/1/report.pdf");
  ASSERT_EQ(pdf.status, 200) << pdf.body.substr(0, 200);
  EXPECT_EQ(pdf.content_type, "application/pdf");
  EXPECT_EQ(pdf.body.rfind("%PDF", 0), 0u);
  EXPECT_EQ(get("/api/gear-runs/9/report.pdf").status, 404);
  EXPECT_TRUE(has(error_of(get("/api/gear-runs/x"), 400), "not a number"));
}

TEST_F(HttpApiTest, ShowIsTheRunAsRunsShowJsonAndAnUnknownRunIs404) {
  fill();
  start();
  Answer a = get("/api/runs/" + std::to_string(ids_[0]));
  ASSERT_EQ(a.status, 200) << a.body;
  EXPECT_EQ(a.j["id"], ids_[0]);
  EXPECT_EQ(a.j["gauge"], "tcp:127.0.0.1:1502");
  EXPECT_EQ(a.j["frame"]["c_offset_deg"], 10.0);
  ASSERT_EQ(a.j["nc_pushes"].size(), 2u) << a.body;
  EXPECT_EQ(a.j["nc_pushes"][1]["table_version"], 2);
  EXPECT_EQ(a.j["nc_pushes"][1]["reason"], "rollback to version 1 by anna");

  EXPECT_TRUE(has(error_of(get("/api/runs/999"), 404), "run 999 is not in run database")) << "names the run";
  EXPECT_TRUE(has(error_of(get("/api/runs/999"), 404), "GET /api/runs lists the ids"));
  EXPECT_TRUE(has(error_of(get("/api/runs/abc"), 400), "run id 'abc' is not a number"));
  EXPECT_TRUE(has(error_of(get("/api/runs/-3"), 400), "run id -3 is out of range"));
}

TEST_F(HttpApiTest, IdsBelowOneAreOutOfRangeNotNotANumber) {
  fill();
  start("t", logging_writes());
  for (const std::string id : {"-1", "0", "99999999999999999999"}) {
    const std::string run = error_of(get("/api/runs/" + id), 400);
    EXPECT_TRUE(has(run, "run id " + id + " is out of range; ids are whole numbers from 1")) << run;
    EXPECT_FALSE(has(run, "not a number")) << run;
    EXPECT_TRUE(has(error_of(get("/api/runs/" + id + "/export"), 400), "ids are whole numbers from 1"));
    const std::string pending = error_of(post("/api/nc/approve/" + id, R"({"by": "anna"})", "t"), 400);
    EXPECT_TRUE(has(pending, "pending table id " + id + " is out of range; ids are whole numbers from 1")) << pending;
  }
  EXPECT_TRUE(log_.all().empty());
}

TEST_F(HttpApiTest, ExportIsTheCsvOfRunsExport) {
  fill();
  start();
  Answer a = get("/api/runs/" + std::to_string(ids_[1]) + "/export");
  ASSERT_EQ(a.status, 200) << a.body;
  EXPECT_TRUE(has(a.content_type, "text/csv")) << a.content_type;
  EXPECT_EQ(a.body.rfind(
                "cam_deg,design_lift_mm,rev1_lift_mm,rev2_lift_mm,rev3_lift_mm,mean_lift_mm,spread_um,"
                "error_um,judged_error_um,correction_um,run_id,machine,part,lobe,started_utc,serial,operator,note\r\n",
                0),
            0u)
      << a.body.substr(0, 800);
  EXPECT_TRUE(has(a.body, "\r\n359,")) << "one row per cam degree";
  Answer c = get("/api/runs/" + std::to_string(ids_[1]) + "/export?comments=true");
  ASSERT_EQ(c.status, 200) << c.body;
  EXPECT_EQ(c.body.rfind("# gaugeloop run " + std::to_string(ids_[1]) + ": intake lobe 1 on g1", 0), 0u) << c.body;
  EXPECT_TRUE(has(c.body, "\r\n" + a.body)) << "the same CSV after the '#' lines";
  EXPECT_TRUE(has(error_of(get("/api/runs/1/export?comment=true"), 400), "it takes comments"));
  EXPECT_EQ(get("/api/runs/999/export").status, 404);
}

TEST_F(HttpApiTest, TrendIsOneLobeOldestFirst) {
  fill();
  start();
  Answer a = get("/api/trend?part=intake&lobe=1&machine=g1");
  ASSERT_EQ(a.status, 200) << a.body;
  ASSERT_EQ(a.j.size(), 2u) << a.body;
  EXPECT_EQ(a.j[0]["id"], ids_[0]);
  EXPECT_EQ(a.j[1]["id"], ids_[1]);
  EXPECT_EQ(a.j[1]["max_abs_error_um"], 4.0);
  EXPECT_TRUE(has(error_of(get("/api/trend?part=intake"), 400), "give both `part` and `lobe`"));
}

TEST_F(HttpApiTest, EventsFilterByKindAndTime) {
  fill();
  start();
  Answer all = get("/api/events");
  ASSERT_EQ(all.status, 200) << all.body;
  ASSERT_EQ(all.j.size(), 2u) << all.body;
  EXPECT_EQ(all.j[0]["code"], "gauge timeout") << "newest first";
  Answer refusals = get("/api/events?kind=refusal");
  ASSERT_EQ(refusals.j.size(), 1u) << refusals.body;
  EXPECT_EQ(refusals.j[0]["message"], "correction 120.0 um at cam degree 95 exceeds the 100 um guard");
  EXPECT_EQ(refusals.j[0]["lobe"], 1);
  EXPECT_EQ(get("/api/events?until=2020-11-21").j.size(), 1u);
  EXPECT_TRUE(has(error_of(get("/api/events?kind=warning"), 400), "`kind` must be fault or refusal or info"));
}

TEST_F(HttpApiTest, NcTableIsTheLastPushWithItsProgramText) {
  fill();
  start();
  for (const char* query : {"", "?program=CAM_INTAKE_L1", "?program=CAM_INTAKE_L1.SPF"}) {
    Answer a = get(std::string("/api/nc/table") + query);
    ASSERT_EQ(a.status, 200) << query << ": " << a.body;
    EXPECT_EQ(a.j["program"], "CAM_INTAKE_L1");
    EXPECT_EQ(a.j["table_version"], 2);
    EXPECT_EQ(a.j["run_id"], ids_[0]);
    EXPECT_EQ(a.j["reason"], "rollback to version 1 by anna");
    EXPECT_EQ(a.j["interpolation"], "CSPLINE");
    EXPECT_EQ(a.j["block_count"], 47);
    EXPECT_EQ(a.j["command_error_um"], 0.497);
    EXPECT_EQ(a.j["program_text"], kProgramV2) << "byte for byte, CR LF kept";
    EXPECT_TRUE(a.j["layer"].is_null()) << "a whole table, not a correction layer";
  }
  const std::string missing = error_of(get("/api/nc/table?program=CAM_EXHAUST_L1"), 404);
  EXPECT_TRUE(has(missing, "no table of program 'CAM_EXHAUST_L1'")) << missing;
  EXPECT_TRUE(has(missing, "the programs are CAM_INTAKE_L1")) << missing;

  Answer history = get("/api/nc/history?program=CAM_INTAKE_L1");
  ASSERT_EQ(history.status, 200) << history.body;
  ASSERT_EQ(history.j.size(), 2u) << history.body;
  EXPECT_EQ(history.j[0]["table_version"], 2) << "newest first";
  EXPECT_FALSE(history.j[0].contains("program_text"));

  Answer pending = get("/api/nc/pending");
  ASSERT_EQ(pending.status, 200) << pending.body;
  ASSERT_EQ(pending.j.size(), 1u) << pending.body;
  EXPECT_EQ(pending.j[0]["id"], pending_id_);
  EXPECT_EQ(pending.j[0]["verdict"], "hold");
  EXPECT_EQ(pending.j[0]["reason"], "correction changes by 60 um");
}

// A correction layer's table names the design table the control adds it to, as it holds it now.
TEST_F(HttpApiTest, NcTableOfACorrectionLayerCarriesItsDesignTable) {
  const std::string part = std::string(GAUGELOOP_SOURCE_DIR) + "/examples/intake_flat_layer.toml";
  testing::CommandResult made = testing::run_command("nc new --part " + part + " --data-dir " + dir_.string());
  ASSERT_EQ(made.exit_code, 0) << made.output;
  start();
  Answer a = get("/api/nc/table?program=CAM_INTAKE_L1");
  ASSERT_EQ(a.status, 200) << a.body;
  ASSERT_TRUE(a.j["layer"].is_object()) << a.body;
  EXPECT_EQ(a.j["layer"]["design_program"], "CAM_INTAKE_L1_DESIGN");
  EXPECT_EQ(a.j["layer"]["design_table_number"], 5);
  EXPECT_EQ(a.j["layer"]["design_text"], testing::slurp(dir_ / "nc" / "CAM_INTAKE_L1_DESIGN.SPF"));
  EXPECT_TRUE(a.j["layer"]["design_problem"].is_null());
  fs::remove(dir_ / "nc" / "CAM_INTAKE_L1_DESIGN.SPF");
  Answer gone = get("/api/nc/table?program=CAM_INTAKE_L1");
  ASSERT_EQ(gone.status, 200) << gone.body;
  EXPECT_TRUE(gone.j["layer"]["design_text"].is_null());
  EXPECT_TRUE(has(gone.j["layer"]["design_problem"].get<std::string>(), "CAM_INTAKE_L1_DESIGN.SPF")) << gone.body;
}

TEST_F(HttpApiTest, NcTableBeforeAnyPushIs404SayingSo) {
  ASSERT_TRUE(RunStore::open(db()).ok());
  start();
  EXPECT_TRUE(has(error_of(get("/api/nc/table"), 404), "no table was pushed yet"));
  EXPECT_EQ(get("/api/nc/history").j, json::array());
}

TEST_F(HttpApiTest, MetricsCountRunsEventsPendingAndTheLastErrorOfEachLobe) {
  fill();
  HttpStatus status;
  status.extra_metrics = [] {
    return "# TYPE gaugeloop_measurements_triggered_total counter\ngaugeloop_measurements_triggered_total 3";
  };
  start("", {}, status);
  Answer a = get("/metrics");
  ASSERT_EQ(a.status, 200) << a.body;
  EXPECT_TRUE(has(a.content_type, "text/plain; version=0.0.4")) << a.content_type;
  for (const std::string& line : std::vector<std::string>{
           "gaugeloop_runs_stored{status=\"measured\"} 3\n",
           "gaugeloop_runs_stored{status=\"pushed\"} 1\n",
           "gaugeloop_events_stored{kind=\"fault\"} 1\n",
           "gaugeloop_events_stored{kind=\"refusal\"} 1\n",
           "gaugeloop_events_stored{kind=\"info\"} 0\n",
           "gaugeloop_pending_tables 1\n",
           "# TYPE gaugeloop_last_run_max_abs_error_meters gauge\n",
           "gaugeloop_last_run_max_abs_error_meters{machine=\"g1\",part=\"intake\",lobe=\"1\"} 4e-06\n",
           "gaugeloop_last_run_max_abs_error_meters{machine=\"g1\",part=\"intake\",lobe=\"2\"} 3e-05\n",
           "gaugeloop_last_run_max_abs_error_meters{machine=\"g2\",part=\"intake\",lobe=\"1\"} 6e-06\n",
           "gaugeloop_last_run_id{machine=\"g1\",part=\"intake\",lobe=\"1\"} " + std::to_string(ids_[1]) + "\n",
           "gaugeloop_last_run_started_timestamp_seconds{machine=\"g2\",part=\"intake\",lobe=\"1\"} 1606032000\n",
           "gaugeloop_database_up 1\n",
           "gaugeloop_measurements_triggered_total 3\n",
       }) {
    EXPECT_TRUE(has(a.body, line)) << "missing: " << line << "in:\n" << a.body;
  }
}

TEST_F(HttpApiTest, WithoutADatabaseReadsAre503AndHealthAndMetricsStillAnswer) {
  start();
  const std::string message = error_of(get("/api/runs"), 503);
  EXPECT_TRUE(has(message, "no run database at " + db().string())) << message;
  EXPECT_TRUE(has(message, "created by the first measurement")) << message;
  EXPECT_FALSE(fs::exists(db())) << "the API never creates the database";
  Answer health = get("/api/health");
  ASSERT_EQ(health.status, 200) << health.body;
  EXPECT_EQ(health.j["database"]["available"], false);
  Answer metrics = get("/metrics");
  ASSERT_EQ(metrics.status, 200) << metrics.body;
  EXPECT_TRUE(has(metrics.body, "gaugeloop_database_up 0\n")) << metrics.body;
  fill();  // the first run arrives: the same server reads it
  EXPECT_EQ(listed("?limit=1"), (Ids{ids_[3]}));
}

TEST_F(HttpApiTest, WritesAreRefusedWhenNoTokenIsConfigured) {
  fill();
  start("", logging_writes());
  EXPECT_TRUE(has(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1})"), 403), "read-only"));
  EXPECT_EQ(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1})", "anything"), 403).empty(), false);
  EXPECT_EQ(post("/api/nc/approve/1", R"({"by": "anna"})").status, 403);
  EXPECT_EQ(post("/api/nc/rollback", R"({"program": "P", "version": 1, "by": "anna"})").status, 403);
  EXPECT_TRUE(log_.all().empty());
}

TEST_F(HttpApiTest, WritesNeedTheConfiguredTokenAndPassTheirArgumentsToTheHooks) {
  fill();
  start("s3cret-token", logging_writes());
  const std::string body = R"({"part": "intake", "lobe": 2, "note": "after dressing"})";
  EXPECT_TRUE(has(error_of(post("/api/measure", body), 401), "Authorization: Bearer <token>"));
  EXPECT_TRUE(has(error_of(post("/api/measure", body, "s3cret-tokeN"), 401), "not the one configured"));
  EXPECT_EQ(post("/api/measure", body, "s3cret").status, 401) << "a prefix is not the token";
  EXPECT_EQ(post("/api/measure", body, "s3cret-token-and-more").status, 401);
  httplib::Headers basic{{"Authorization", "Basic czNjcmV0LXRva2Vu"}};
  EXPECT_EQ(answer_of(client_->Post("/api/measure", basic, body, "application/json")).status, 401);
  EXPECT_TRUE(log_.all().empty()) << "no hook runs without the token";

  Answer measured = post("/api/measure", body, "s3cret-token");
  ASSERT_EQ(measured.status, 200) << measured.body;
  EXPECT_EQ(measured.j["queued"], true);
  Answer approved =
      post("/api/nc/approve/" + std::to_string(pending_id_), R"({"by": "anna", "note": "ok"})", "s3cret-token");
  ASSERT_EQ(approved.status, 200) << approved.body;
  EXPECT_EQ(approved.j["approved"], pending_id_);
  Answer rolled =
      post("/api/nc/rollback", R"({"program": "CAM_INTAKE_L1", "version": 1, "by": "bert"})", "s3cret-token");
  ASSERT_EQ(rolled.status, 200) << rolled.body;
  EXPECT_EQ(rolled.j["version"], 2);
  EXPECT_EQ(log_.all(), (std::vector<std::string>{"measure intake 2 after dressing",
                                                  "approve " + std::to_string(pending_id_) + " anna ok",
                                                  "rollback CAM_INTAKE_L1 1 bert"}));
}

TEST_F(HttpApiTest, HookErrorsChooseTheStatusAndKeepTheirMessage) {
  HttpWrites w;
  w.trigger_measure = [](const std::string&, int, const std::string&, const std::string&, const std::string&,
                         std::optional<double>) -> Result<json> {
    return make_error(ErrorCode::kRefused, "a measurement of intake lobe 1 is running; try again when it is done");
  };
  w.approve = [](std::int64_t, const std::string&, const std::string&) -> Result<json> {
    return make_error(ErrorCode::kNotFound, "no pending table 7");
  };
  w.rollback = [](const std::string&, int, const std::string&) -> Result<json> {
    return make_error(ErrorCode::kGaugeTimeout, "gauge stopped answering");
  };
  start("t", w);
  EXPECT_EQ(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1})", "t"), 409),
            "a measurement of intake lobe 1 is running; try again when it is done");
  EXPECT_EQ(error_of(post("/api/nc/approve/7", R"({"by": "anna"})", "t"), 404), "no pending table 7");
  EXPECT_EQ(error_of(post("/api/nc/rollback", R"({"program": "P", "version": 1, "by": "a"})", "t"), 502),
            "gauge stopped answering");
}

TEST_F(HttpApiTest, AWriteTheServiceDoesNotProvideIs501) {
  start("t");
  EXPECT_TRUE(has(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1})", "t"), 501), "measurement"));
  EXPECT_EQ(post("/api/nc/approve/1", R"({"by": "anna"})", "t").status, 501);
  EXPECT_EQ(post("/api/nc/rollback", R"({"program": "P", "version": 1, "by": "a"})", "t").status, 501);
}

TEST_F(HttpApiTest, MalformedBodiesAre400SayingWhatIsWrong) {
  start("t", logging_writes());
  EXPECT_TRUE(has(error_of(post("/api/measure", R"({"part": "intake", "lobe": )", "t"), 400),
                  "the request body is not JSON: parse error at line 1"));
  EXPECT_TRUE(has(error_of(post("/api/measure", "", "t"), 400), "the request body is empty; send a JSON object"));
  EXPECT_TRUE(has(error_of(post("/api/measure", "[1, 2]", "t"), 400), "must be a JSON object, not array"));
  EXPECT_TRUE(has(error_of(post("/api/measure", R"({"lobe": 1})", "t"), 400), "needs `part`"));
  EXPECT_TRUE(has(error_of(post("/api/measure", R"({"part": 7, "lobe": 1})", "t"), 400),
                  "`part` must be a string, not number"));
  EXPECT_TRUE(has(error_of(post("/api/measure", R"({"part": "intake", "lobe": "one"})", "t"), 400),
                  "`lobe` must be a whole number from 1 to 1000, not \"one\""));
  EXPECT_TRUE(has(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1.5})", "t"), 400), "`lobe`"));
  EXPECT_TRUE(has(error_of(post("/api/measure", R"({"part": "intake", "lobe": 0})", "t"), 400), "`lobe`"));
  EXPECT_TRUE(has(error_of(post("/api/measure", R"({"part": "intake", "lobe": 1e300})", "t"), 400), "`lobe`"));
  EXPECT_TRUE(
      has(error_of(post("/api/measure", R"({"part": "intake", "lobes": 1})", "t"), 400), "unknown field `lobes`"));
  EXPECT_TRUE(has(error_of(post("/api/nc/approve/x1", R"({"by": "anna"})", "t"), 400), "pending table id 'x1'"));
  EXPECT_TRUE(has(error_of(post("/api/nc/approve/1", R"({"note": "no name"})", "t"), 400), "needs `by`"));
  EXPECT_TRUE(
      has(error_of(post("/api/nc/rollback", R"({"program": "P", "version": -1, "by": "a"})", "t"), 400), "`version`"));
  EXPECT_TRUE(has(error_of(post("/api/measure", "\xff\xfe{}", "t"), 400), "not JSON")) << "not UTF-8";
  EXPECT_TRUE(has(error_of(post("/api/measure", std::string(20000, '['), "t"), 400), "not JSON"));
  // Refused on its Content-Length, before the body is read: a client may still be sending it.
  EXPECT_EQ(testing::raw_http(api_->port(),
                              "POST /api/measure HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer t\r\n"
                              "Content-Type: application/json\r\nContent-Length: 102400\r\n\r\n" +
                                  std::string(100 * 1024, ' '))
                .rfind("HTTP/1.1 413 ", 0),
            0u);
  EXPECT_TRUE(log_.all().empty());
  EXPECT_EQ(get("/api/health").status, 200) << "still serving";
}

// The JSON error of a raw answer (head and body), after checking its status line.
std::string raw_error(const std::string& answer, int status) {
  EXPECT_EQ(answer.rfind("HTTP/1.1 " + std::to_string(status) + " ", 0), 0u) << answer;
  const std::size_t body = answer.find("\r\n\r\n");
  const json j = json::parse(body == std::string::npos ? "" : answer.substr(body + 4), nullptr, false);
  EXPECT_TRUE(j.is_object() && j.contains("error")) << answer;
  return j.is_object() ? j.value("error", std::string()) : std::string();
}

TEST_F(HttpApiTest, AWriteWithoutContentLengthIs411AndChunkedIsRead) {
  start("t", logging_writes());
  const std::string head =
      "POST /api/measure HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer t\r\nContent-Type: application/json\r\n";
  const std::string body = R"({"part": "intake", "lobe": 1})";
  const std::string no_length = raw_error(testing::raw_http(api_->port(), head + "\r\n" + body), 411);
  EXPECT_TRUE(has(no_length, "needs a Content-Length header (or Transfer-Encoding: chunked)")) << no_length;
  EXPECT_TRUE(log_.all().empty());

  char size[16];
  std::snprintf(size, sizeof size, "%zx", body.size());
  const std::string chunked = testing::raw_http(
      api_->port(), head + "Transfer-Encoding: chunked\r\n\r\n" + size + "\r\n" + body + "\r\n0\r\n\r\n");
  EXPECT_EQ(chunked.rfind("HTTP/1.1 200 ", 0), 0u) << chunked;
  EXPECT_EQ(log_.all(), std::vector<std::string>{"measure intake 1 "});

  const std::string big = std::string(70 * 1024, ' ');
  std::snprintf(size, sizeof size, "%zx", big.size());
  const std::string too_large = raw_error(testing::raw_http(api_->port(), head + "Transfer-Encoding: chunked\r\n\r\n" +
                                                                              size + "\r\n" + big + "\r\n0\r\n\r\n"),
                                          413);
  EXPECT_TRUE(has(too_large, "larger than 64 KiB")) << too_large;
  EXPECT_TRUE(has(raw_error(testing::raw_http(api_->port(), head + "Transfer-Encoding: gzip\r\n\r\n"), 501),
                  "Transfer-Encoding 'gzip' is not supported"));
  EXPECT_EQ(log_.all().size(), 1u);
}

TEST_F(HttpApiTest, AWriteThatIsNotJsonIs415) {
  start("t", logging_writes());
  const std::string body = R"({"part": "intake", "lobe": 1})";
  httplib::Headers token{{"Authorization", "Bearer t"}};
  const std::string plain = error_of(answer_of(client_->Post("/api/measure", token, body, "text/plain")), 415);
  EXPECT_TRUE(has(plain, "Content-Type 'text/plain' is not JSON")) << plain;
  EXPECT_TRUE(has(plain, "Content-Type: application/json")) << plain;
  EXPECT_EQ(answer_of(client_->Post("/api/measure", token, body, "application/x-www-form-urlencoded")).status, 415);
  EXPECT_EQ(answer_of(client_->Post("/api/measure", token, body, "multipart/form-data; boundary=x")).status, 415);
  const std::string none =
      raw_error(testing::raw_http(api_->port(),
                                  "POST /api/measure HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer t\r\n"
                                  "Content-Length: " +
                                      std::to_string(body.size()) + "\r\n\r\n" + body),
                415);
  EXPECT_TRUE(has(none, "no Content-Type")) << none;
  EXPECT_TRUE(log_.all().empty());
  for (const char* type : {"application/json; charset=utf-8", "Application/JSON", "application/json ;charset=UTF-8"}) {
    EXPECT_EQ(answer_of(client_->Post("/api/measure", token, body, type)).status, 200) << type;
  }
  EXPECT_EQ(log_.all().size(), 3u);
}

TEST_F(HttpApiTest, TheTokenIsCheckedBeforeTheBodyIsRead) {
  start("t", logging_writes());
  const auto big_post = [this](const std::string& headers) {
    return testing::raw_http(api_->port(), "POST /api/measure HTTP/1.1\r\nHost: x\r\n" + headers +
                                               "Content-Length: 102400\r\n\r\n" + std::string(100 * 1024, ' '));
  };
  EXPECT_TRUE(has(raw_error(big_post("Content-Type: application/json\r\n"), 401), "Authorization: Bearer <token>"))
      << "not 413: nothing of the body was read";
  EXPECT_EQ(raw_error(big_post("Content-Type: text/plain\r\n"), 401).empty(), false) << "not 415";
  EXPECT_TRUE(has(raw_error(big_post("Authorization: Bearer t\r\nContent-Type: application/json\r\n"), 413),
                  "larger than 64 KiB"));
  EXPECT_TRUE(log_.all().empty());
}

TEST_F(HttpApiTest, ABodyWhereNoneIsTakenIsRefusedUnread) {
  fill();
  start("t", logging_writes());
  const std::string get = raw_error(
      testing::raw_http(api_->port(), "GET /api/runs HTTP/1.1\r\nHost: x\r\nContent-Length: 4\r\n\r\nabcd"), 400);
  EXPECT_TRUE(has(get, "GET /api/runs takes no request body")) << get;
  EXPECT_EQ(raw_error(testing::raw_http(api_->port(),
                                        "GET /api/runs HTTP/1.1\r\nHost: x\r\n"
                                        "Transfer-Encoding: chunked\r\n\r\n4\r\nabcd\r\n0\r\n\r\n"),
                      400)
                .empty(),
            false);
  EXPECT_TRUE(has(raw_error(testing::raw_http(api_->port(),
                                              "PUT /api/runs HTTP/1.1\r\nHost: x\r\n"
                                              "Transfer-Encoding: chunked\r\n\r\n"),
                            405),
                  "use GET"));
  EXPECT_TRUE(has(raw_error(testing::raw_http(api_->port(), "POST /api/nothing HTTP/1.1\r\nHost: x\r\n\r\n"), 404),
                  "no such endpoint"));
  EXPECT_EQ(listed("?limit=1"), (Ids{ids_[3]})) << "still serving";
}

TEST_F(HttpApiTest, UnknownPathsAre404AndWrongMethods405InJson) {
  start();
  EXPECT_TRUE(has(error_of(get("/api/nothing"), 404), "no such endpoint: GET /api/nothing"));
  EXPECT_EQ(error_of(get("/nothing"), 404).empty(), false);  // "/" leads to the pages (tests/service)
  EXPECT_EQ(error_of(get("/api/runs/1/export/more"), 404).empty(), false);
  EXPECT_TRUE(has(error_of(get("/api/measure"), 405), "use POST"));
  EXPECT_TRUE(has(error_of(post("/api/runs", "{}"), 405), "use GET"));
}

TEST_F(HttpApiTest, BadQueryValuesAre400NamingTheParameter) {
  fill();
  start();
  EXPECT_TRUE(has(error_of(get("/api/runs?lobe=abc"), 400),
                  "query parameter `lobe` must be a whole number from 1 to 1000, not 'abc'"));
  EXPECT_TRUE(has(error_of(get("/api/runs?lobe=1x"), 400), "`lobe`"));
  EXPECT_TRUE(has(error_of(get("/api/runs?limit=0"), 400), "`limit`"));
  EXPECT_TRUE(has(error_of(get("/api/runs?limit=99999999999999999999"), 400), "`limit`"));
  EXPECT_TRUE(has(error_of(get("/api/runs?since=22.11.2026"), 400),
                  "query parameter `since`: '22.11.2026' is not a UTC date or time; write 2026-11-22"));
  EXPECT_TRUE(has(error_of(get("/api/runs?until=2026-02-30"), 400), "not a real date"));
  EXPECT_TRUE(has(error_of(get("/api/runs?status=done"), 400), "`status` must be measured or pushed"));
  EXPECT_TRUE(has(error_of(get("/api/runs?parts=intake"), 400), "unknown query parameter `parts`"));
  EXPECT_TRUE(has(error_of(get("/api/runs?lobe=1&lobe=2"), 400), "`lobe` is given twice"));
  EXPECT_TRUE(has(error_of(get("/api/nc/pending?all=maybe"), 400), "`all` must be true or false"));
  EXPECT_TRUE(has(error_of(get("/api/runs?lobe=%FF"), 400), "`lobe`")) << "not UTF-8, still JSON";
  Answer odd = get("/api/runs?part=%FF%FE");
  EXPECT_EQ(odd.status, 200) << odd.body;
  EXPECT_EQ(odd.j, json::array());
}

TEST_F(HttpApiTest, AnExceptionInAHandlerIs500AndTheServerKeepsServing) {
  fill();
  HttpStatus status;
  status.health = []() -> json { throw std::runtime_error("health hook broke"); };
  start("", {}, status);
  const std::string message = error_of(get("/api/health"), 500);
  EXPECT_TRUE(has(message, "health hook broke")) << message;
  EXPECT_TRUE(has(message, "please report it")) << message;
  EXPECT_EQ(listed("?limit=1"), (Ids{ids_[3]}));
}

TEST_F(HttpApiTest, ConcurrentReadersEachGetWholeAnswers) {
  fill();
  start();
  std::vector<std::thread> readers;
  std::vector<int> ok(6, 0);
  for (std::size_t t = 0; t < ok.size(); ++t) {
    readers.emplace_back([this, t, &ok] {
      httplib::Client c("127.0.0.1", api_->port());
      for (int i = 0; i < 10; ++i) {
        httplib::Result r = c.Get(t % 2 == 0 ? "/api/runs" : "/metrics");
        if (r && r->status == 200) ++ok[t];
      }
    });
  }
  for (std::thread& r : readers) r.join();
  EXPECT_EQ(ok, std::vector<int>(6, 10));
}

TEST_F(HttpApiTest, StopClosesThePortAndIsIdempotent) {
  start();
  const int port = api_->port();
  EXPECT_EQ(get("/api/health").status, 200);
  api_->stop();
  api_->stop();
  httplib::Client c("127.0.0.1", port);
  EXPECT_FALSE(c.Get("/api/health")) << "nothing listens after stop";
}

// A head that does not come whole within the front's head timeout is answered 408 and closed;
// the next client is served.
TEST_F(HttpApiTest, AHeadThatDoesNotComeWholeInTimeIsAnswered408) {
  ASSERT_TRUE(RunStore::open(db()).ok());
  HttpSettings settings;
  settings.port = 0;
  HttpFrontLimits limits;
  limits.head_timeout = std::chrono::milliseconds(300);
  Result<std::unique_ptr<HttpApi>> api = HttpApi::start(settings, db(), {}, {}, limits);
  ASSERT_TRUE(api.ok()) << api.error().message;
  const int port = (*api)->port();
  const std::string partial = testing::raw_http(port, "GET /api/health HTTP/1.1\r\nHost: x\r\n");
  EXPECT_EQ(partial.rfind("HTTP/1.1 408", 0), 0u) << partial;
  EXPECT_TRUE(has(partial, "the request's head did not come whole within 300 ms")) << partial;
  const std::string whole = testing::raw_http(port, "GET /api/health HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(whole.rfind("HTTP/1.1 200", 0), 0u) << whole.substr(0, 200);
  // Passed on with the client's address, one request a connection.
  EXPECT_TRUE(has(whole, "Connection: close")) << whole.substr(0, 400);
}

TEST_F(HttpApiTest, ABusyPortIsAnErrorNamingTheAddress) {
  start();
  HttpSettings taken;
  taken.port = api_->port();
  Result<std::unique_ptr<HttpApi>> second = HttpApi::start(taken, db(), {}, {});
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.error().code, ErrorCode::kIo);
  EXPECT_TRUE(has(second.error().message, "127.0.0.1:" + std::to_string(taken.port))) << second.error().message;
}

TEST(JobReportJson, WhatARefusedRunDidNotBuildOrPushIsNull) {
  JobReport refused;
  refused.run_id = 12;
  refused.verdict = CompensationVerdict::kRefuse;
  refused.analysis.max_abs_error_um = 130.0;
  refused.correction_max_um = 125.0;
  refused.not_pushed_reason = "correction 125.0 um exceeds the 100 um guard";
  const json j = job_report_json(refused);
  EXPECT_EQ(j["run_id"], 12);
  EXPECT_EQ(j["pushed"], false);
  EXPECT_EQ(j["verdict"], "refuse");
  EXPECT_EQ(j["max_abs_error_um"], 130.0) << "measured: a figure";
  EXPECT_EQ(j["correction_max_um"], 125.0) << "computed: the correction that was refused";
  for (const char* field :
       {"interpolation", "table_blocks", "command_error_um", "nc_file", "table_version", "pending_id"}) {
    ASSERT_TRUE(j.contains(field)) << field << " in " << j.dump();
    EXPECT_TRUE(j[field].is_null()) << field << " in " << j.dump();
  }
  EXPECT_EQ(j["not_pushed_reason"], "correction 125.0 um exceeds the 100 um guard");

  JobReport pushed = refused;
  pushed.verdict = CompensationVerdict::kApply;
  pushed.not_pushed_reason.clear();
  pushed.interpolation = "cspline";
  pushed.table_blocks = 45;
  pushed.command_error_um = 0.475;
  pushed.nc_file = "/srv/nc/CAM_INTAKE_L1.SPF";
  pushed.table_version = 3;
  const json p = job_report_json(pushed);
  EXPECT_EQ(p["interpolation"], "cspline");
  EXPECT_EQ(p["table_blocks"], 45);
  EXPECT_EQ(p["nc_file"], "/srv/nc/CAM_INTAKE_L1.SPF");
  EXPECT_EQ(p["table_version"], 3);
  EXPECT_TRUE(p["not_pushed_reason"].is_null()) << p.dump();
  EXPECT_EQ(p.size(), j.size()) << "every field in every answer";
}

// A self-signed certificate for 127.0.0.1 made with the openssl command, and the key.
struct SelfSigned {
  fs::path cert;
  fs::path key;
};

SelfSigned make_certificate(const fs::path& dir) {
  SelfSigned out{dir / "cert.pem", dir / "key.pem"};
  const testing::CommandResult made = testing::run_shell(
      "openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -subj /CN=localhost "
      "-addext subjectAltName=IP:127.0.0.1,DNS:localhost -days 1 -keyout " +
      out.key.string() + " -out " + out.cert.string());
  EXPECT_EQ(made.exit_code, 0) << made.output;
  return out;
}

TEST_F(HttpApiTest, WithACertificateAndKeyTheApiIsHttpsOnly) {
  fill();
  const SelfSigned tls = make_certificate(dir_);
  HttpSettings settings;
  settings.port = 0;
  settings.tls_cert = tls.cert;
  settings.tls_key = tls.key;
  settings.token = "s3cret-token";
  Result<std::unique_ptr<HttpApi>> api = HttpApi::start(settings, db(), logging_writes(), {});
  ASSERT_TRUE(api.ok()) << api.error().message;
  const std::string port = std::to_string((*api)->port());
  EXPECT_TRUE((*api)->alive());

  const testing::CommandResult https = testing::run_shell("curl -sS --max-time 60 --cacert " + tls.cert.string() +
                                                          " https://127.0.0.1:" + port + "/api/health");
  ASSERT_EQ(https.exit_code, 0) << https.output;
  const json health = json::parse(https.output, nullptr, false);
  EXPECT_EQ(health["database"]["available"], true) << https.output;
  EXPECT_EQ(health["version"], GAUGELOOP_VERSION) << https.output;

  const testing::CommandResult runs = testing::run_shell("curl -sS --max-time 60 --cacert " + tls.cert.string() +
                                                         " 'https://127.0.0.1:" + port + "/api/runs?limit=1'");
  ASSERT_EQ(runs.exit_code, 0) << runs.output;
  EXPECT_EQ(json::parse(runs.output, nullptr, false)[0]["id"], ids_[3]) << runs.output;
  const testing::CommandResult write = testing::run_shell(
      "curl -sS --max-time 60 --cacert " + tls.cert.string() + " -H 'Authorization: Bearer s3cret-token' " +
      "-H 'Content-Type: application/json' -d '{\"part\": \"intake\", \"lobe\": 2}' https://127.0.0.1:" + port +
      "/api/measure");
  ASSERT_EQ(write.exit_code, 0) << write.output;
  EXPECT_EQ(json::parse(write.output, nullptr, false)["queued"], true) << write.output;
  EXPECT_EQ(log_.all(), std::vector<std::string>{"measure intake 2 "});

  const testing::CommandResult plain =
      testing::run_shell("curl -sS --max-time 60 http://127.0.0.1:" + port + "/api/health");
  EXPECT_NE(plain.exit_code, 0) << "plain HTTP to the HTTPS port: " << plain.output;
  EXPECT_FALSE(has(plain.output, "\"version\"")) << plain.output;
  const testing::CommandResult untrusted =
      testing::run_shell("curl -sS --max-time 60 https://127.0.0.1:" + port + "/api/health");
  EXPECT_NE(untrusted.exit_code, 0) << "a certificate curl was not told to trust: " << untrusted.output;
  (*api)->stop();
}

TEST_F(HttpApiTest, AKeyOrCertificateThatCannotBeLoadedIsRefusedNamingTheFiles) {
  const SelfSigned tls = make_certificate(dir_);
  const fs::path garbage = dir_ / "garbage.pem";
  std::ofstream(garbage) << "-----BEGIN PRIVATE KEY-----\nnot a key\n-----END PRIVATE KEY-----\n";
  HttpSettings settings;
  settings.port = 0;
  settings.tls_cert = tls.cert;
  settings.tls_key = garbage;
  Result<std::unique_ptr<HttpApi>> bad_key = HttpApi::start(settings, db(), {}, {});
  ASSERT_FALSE(bad_key.ok());
  EXPECT_EQ(bad_key.error().code, ErrorCode::kInvalidInput);
  EXPECT_TRUE(has(bad_key.error().message, garbage.string())) << bad_key.error().message;
  EXPECT_TRUE(has(bad_key.error().message, tls.cert.string())) << bad_key.error().message;

  settings.tls_cert = garbage;
  settings.tls_key = tls.key;
  Result<std::unique_ptr<HttpApi>> bad_cert = HttpApi::start(settings, db(), {}, {});
  ASSERT_FALSE(bad_cert.ok());
  EXPECT_TRUE(has(bad_cert.error().message, garbage.string())) << bad_cert.error().message;

  fs::create_directory(dir_ / "other");
  const SelfSigned other = make_certificate(dir_ / "other");
  settings.tls_cert = tls.cert;
  settings.tls_key = other.key;
  Result<std::unique_ptr<HttpApi>> not_its_key = HttpApi::start(settings, db(), {}, {});
  ASSERT_FALSE(not_its_key.ok()) << "a key that is not the certificate's";
  EXPECT_TRUE(has(not_its_key.error().message, other.key.string())) << not_its_key.error().message;

  settings.tls_key = dir_ / "missing.pem";
  Result<std::unique_ptr<HttpApi>> missing = HttpApi::start(settings, db(), {}, {});
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kInvalidInput);
  EXPECT_TRUE(has(missing.error().message, "tls_key file " + (dir_ / "missing.pem").string()))
      << missing.error().message;

  settings.tls_key.clear();
  Result<std::unique_ptr<HttpApi>> half = HttpApi::start(settings, db(), {}, {});
  ASSERT_FALSE(half.ok());
  EXPECT_TRUE(has(half.error().message, "tls_cert and tls_key go together")) << half.error().message;
}

}  // namespace
}  // namespace gaugeloop

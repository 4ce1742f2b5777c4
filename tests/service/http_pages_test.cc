// What the pages need of the HTTP API, in-process: the page files served from the binary, the
// run's plot and PDF report, the trend plot, a table's text by version, a pending table's
// text with the version it would become and its change from the table in force, checking a
// token without writing, and rejecting a pending table with the token.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>

#include "core/tolerance.h"
#include "service/http_api.h"
#include "service/web_assets.h"
#include "storage/run_store.h"
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

const char* const kProgramV1 = "; CAM_INTAKE_L1 version 1\r\nCTABDEF(1,1)\r\nC0 X0\r\nCTABEND\r\n";
const char* const kProgramV2 = "; CAM_INTAKE_L1 version 2\r\nCTABDEF(1,1)\r\nC0 X0.0010\r\nCTABEND\r\n";

class HttpPagesTest : public ::testing::Test {
 protected:
  void TearDown() override { api_.reset(); }

  fs::path db() const { return tmp_.path() / "gaugeloop.sqlite"; }

  // Runs 1 and 2 of intake lobe 1 judged against lift error +-12 um (the second out); version
  // 1 and 2 of CAM_INTAKE_L1 pushed; one table pending for it.
  void fill() {
    Result<RunStore> store = RunStore::open(db());
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (const auto& [started, max_um] : {std::pair{"2026-11-20T08:00:00Z", 8.0}, {"2026-11-21T08:00:00Z", 15.0}}) {
      RunRecord r = testing::sample_run("intake_flat", 1, "grinder-1", started, max_um);
      r.serial = "S-7";
      r.characteristics = {single_characteristic("lift_error", "um", max_um, Limits{-12.0, 12.0})};
      Result<std::int64_t> id = store->insert_run(r);
      ASSERT_TRUE(id.ok()) << id.error().message;
      ids_.push_back(*id);
    }
    NcPush push;
    push.nc_file = "/nc/CAM_INTAKE_L1.SPF";
    ASSERT_TRUE(store->record_push(ids_[0], push, kProgramV1).ok());
    ASSERT_TRUE(store->record_push(ids_[1], push, kProgramV2).ok());
    PendingTable pending;
    pending.run_id = ids_[1];
    pending.nc_file = "/nc/CAM_INTAKE_L1.SPF";
    pending.program_text = "; pending table\r\n";
    pending.verdict = PendingVerdict::kHold;
    pending.reason = "correction changes by 60 um";
    Result<std::int64_t> p = store->add_pending(pending);
    ASSERT_TRUE(p.ok()) << p.error().message;
    pending_id_ = *p;
  }

  void start(const std::string& token = "", HttpStatus status = {}, HttpWrites writes = {}) {
    HttpSettings settings;
    settings.port = 0;
    settings.token = token;
    Result<std::unique_ptr<HttpApi>> api = HttpApi::start(settings, db(), std::move(writes), std::move(status));
    ASSERT_TRUE(api.ok()) << api.error().message;
    api_ = std::move(*api);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", api_->port());
  }

  using Answer = testing::HttpAnswer;
  static Answer answer_of(const httplib::Result& r) { return testing::answer_of(r); }

  static std::string header(const Answer& a, const std::string& name) {
    const auto it = a.headers.find(name);
    return it == a.headers.end() ? std::string() : it->second;
  }

  Answer get(const std::string& path) { return answer_of(client_->Get(path)); }

  Answer post(const std::string& path, const std::string& body, const std::string& token = "") {
    httplib::Headers headers;
    if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
    return answer_of(client_->Post(path, headers, body, "application/json"));
  }

  static std::string error_of(const Answer& a, int status) {
    EXPECT_EQ(a.status, status) << a.body;
    EXPECT_EQ(a.content_type, "application/json") << a.body;
    return a.j.is_object() ? a.j.value("error", std::string()) : std::string();
  }

  std::string pending_status() {
    Answer a = get("/api/nc/pending?all=true");
    EXPECT_EQ(a.status, 200) << a.body;
    for (const json& t : a.j) {
      if (t["id"] == pending_id_) return t["status"].get<std::string>();
    }
    return "missing";
  }

  testing::TempDir tmp_;
  std::vector<std::int64_t> ids_;
  std::int64_t pending_id_ = 0;
  std::unique_ptr<HttpApi> api_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(HttpPagesTest, PageFilesAreServedFromTheBinaryWithTheirContentTypes) {
  start();
  Answer index = get("/ui/");
  ASSERT_EQ(index.status, 200) << index.body;
  EXPECT_EQ(index.content_type, "text/html; charset=utf-8");
  EXPECT_TRUE(has(index.body, "<script src=\"/ui/app.js\"></script>")) << index.body;
  EXPECT_TRUE(has(index.body, "href=\"/ui/style.css\"")) << index.body;
  EXPECT_EQ(header(index, "Cache-Control"), "no-cache");
  EXPECT_TRUE(has(header(index, "Content-Security-Policy"), "default-src 'self'")) << "no script from elsewhere";
  EXPECT_EQ(header(index, "X-Content-Type-Options"), "nosniff");
  EXPECT_EQ(get("/ui/index.html").body, index.body);
  Answer js = get("/ui/app.js");
  ASSERT_EQ(js.status, 200);
  EXPECT_EQ(js.content_type, "text/javascript; charset=utf-8");
  EXPECT_TRUE(has(js.body, "/api/runs")) << "the app calls the API";
  Answer css = get("/ui/style.css");
  ASSERT_EQ(css.status, 200);
  EXPECT_EQ(css.content_type, "text/css; charset=utf-8");
  // What the binary holds is the files in the source tree, byte for byte.
  const WebAsset* asset = find_web_asset("app.js");
  ASSERT_NE(asset, nullptr);
  EXPECT_EQ(js.body, std::string(asset->body));
  EXPECT_EQ(find_web_asset("nothing.js"), nullptr);
}

TEST_F(HttpPagesTest, NoPageReachesAnotherHost) {
  start();
  for (const char* file : {"/ui/", "/ui/app.js", "/ui/style.css"}) {
    const std::string body = get(file).body;
    EXPECT_FALSE(has(body, "http://") || has(body, "https://") || has(body, "//cdn")) << file;
  }
}

TEST_F(HttpPagesTest, RootAndUiLeadToThePages) {
  start();
  for (const char* path : {"/", "/ui"}) {
    Answer a = get(path);
    EXPECT_EQ(a.status, 302) << path;
    EXPECT_EQ(header(a, "Location"), "/ui/") << path;
  }
}

TEST_F(HttpPagesTest, UnknownPageFilesAre404InJsonAndTheApiAnswersStayAsTheyWere) {
  start();
  EXPECT_TRUE(has(error_of(get("/ui/nothing.js"), 404), "no such page file: /ui/nothing.js"));
  EXPECT_TRUE(has(error_of(get("/ui/a/b"), 404), "no such endpoint"));
  EXPECT_TRUE(has(error_of(get("/api/nothing"), 404), "no such endpoint: GET /api/nothing"));
  EXPECT_TRUE(has(error_of(get("/nothing"), 404), "the pages at /ui/"));
  EXPECT_TRUE(has(error_of(post("/ui/", "{}"), 405), "use GET"));
  EXPECT_TRUE(has(error_of(get("/api/nc/reject/1"), 405), "use POST"));
}

TEST_F(HttpPagesTest, ARunsPlotIsItsErrorAsSvgWithItsToleranceBand) {
  fill();
  start();
  Answer a = get("/api/runs/" + std::to_string(ids_[0]) + "/plot.svg");
  ASSERT_EQ(a.status, 200) << a.body;
  EXPECT_EQ(a.content_type, "image/svg+xml");
  EXPECT_TRUE(has(a.body, "<svg")) << a.body.substr(0, 200);
  EXPECT_TRUE(has(a.body, "Run " + std::to_string(ids_[0]) + " \u00b7 intake_flat lobe 1 \u00b7 grinder-1"));
  EXPECT_TRUE(has(a.body, "serial S-7"));
  EXPECT_TRUE(has(a.body, "\u00b112.0 \u00b5m")) << "the lift error's tolerance";
  EXPECT_TRUE(has(a.body, "max 8.00 \u00b5m"));
  EXPECT_TRUE(has(error_of(get("/api/runs/99/plot.svg"), 404), "GET /api/runs lists the ids"));
  EXPECT_TRUE(has(error_of(get("/api/runs/x/plot.svg"), 400), "run id 'x' is not a number"));
  EXPECT_TRUE(has(error_of(get("/api/runs/1/plot.svg?size=2"), 400), "unknown query parameter `size`"));
  // For a phone: the same run, stacked in 380 px.
  const auto narrow = get("/api/runs/" + std::to_string(ids_[0]) + "/plot.svg?layout=narrow");
  EXPECT_EQ(narrow.status, 200);
  EXPECT_TRUE(has(narrow.body, "width=\"380\"")) << narrow.body.substr(0, 300);
  EXPECT_TRUE(has(narrow.body, "max 8.00 \u00b5m"));
  EXPECT_TRUE(has(error_of(get("/api/runs/1/plot.svg?layout=tall"), 400), "layout `tall`: give wide or narrow"));
}

TEST_F(HttpPagesTest, ARunsReportIsAPdfFromATemporaryFileThatIsRemoved) {
  fill();
  // The report's temporary directory goes where TMPDIR says: here, to see it removed.
  const fs::path scratch = tmp_.path() / "scratch";
  fs::create_directory(scratch);
  const char* old_tmpdir = ::getenv("TMPDIR");
  const std::string saved = old_tmpdir != nullptr ? old_tmpdir : "";
  ::setenv("TMPDIR", scratch.c_str(), 1);
  start();
  Answer a = get("/api/runs/" + std::to_string(ids_[1]) + "/report.pdf");
  if (old_tmpdir != nullptr) {
    ::setenv("TMPDIR", saved.c_str(), 1);
  } else {
    ::unsetenv("TMPDIR");
  }
  ASSERT_EQ(a.status, 200) << a.body.substr(0, 300);
  EXPECT_EQ(a.content_type, "application/pdf");
  EXPECT_EQ(a.body.substr(0, 5), "%PDF-");
  EXPECT_GT(a.body.size(), 10000u) << "a whole page";
  EXPECT_EQ(header(a, "Content-Disposition"), "inline; filename=\"run" + std::to_string(ids_[1]) + ".pdf\"");
  EXPECT_TRUE(fs::is_empty(scratch)) << "the temporary file is removed";
  EXPECT_TRUE(has(error_of(get("/api/runs/99/report.pdf"), 404), "run"));
}

TEST_F(HttpPagesTest, TheTrendPlotShowsOneCharacteristicOfALobeWithItsLimits) {
  fill();
  start();
  Answer a = get("/api/trend.svg?part=intake_flat&lobe=1");
  ASSERT_EQ(a.status, 200) << a.body;
  EXPECT_EQ(a.content_type, "image/svg+xml");
  EXPECT_TRUE(has(a.body, "<svg")) << a.body.substr(0, 200);
  // The same picture (cairo numbers its surfaces across the process: ids aside).
  auto without_ids = [](const std::string& svg) {
    return std::regex_replace(svg, std::regex("surface[0-9]+"), "surface");
  };
  EXPECT_EQ(without_ids(get("/api/trend.svg?part=intake_flat&lobe=1&key=lift_error").body), without_ids(a.body));
  EXPECT_TRUE(has(error_of(get("/api/trend.svg?part=intake_flat"), 400), "give both `part` and `lobe`"));
  EXPECT_TRUE(has(error_of(get("/api/trend.svg?part=intake_flat&lobe=1&key=nothing"), 404), "lift_error"))
      << "names the keys the runs have";
  EXPECT_TRUE(has(error_of(get("/api/trend.svg?part=exhaust&lobe=1"), 404), "no runs of exhaust lobe 1"));
  EXPECT_TRUE(has(error_of(get("/api/trend.svg?part=intake_flat&lobe=1&colour=red"), 400), "`colour`"));
}

TEST_F(HttpPagesTest, ATableIsReadByVersionForADiff) {
  fill();
  start();
  Answer v1 = get("/api/nc/table?program=CAM_INTAKE_L1&version=1");
  ASSERT_EQ(v1.status, 200) << v1.body;
  EXPECT_EQ(v1.j["table_version"], 1);
  EXPECT_EQ(v1.j["program_text"], kProgramV1);
  Answer now = get("/api/nc/table?program=CAM_INTAKE_L1");
  EXPECT_EQ(now.j["table_version"], 2) << "without a version: the one in force";
  EXPECT_EQ(now.j["program_text"], kProgramV2);
  EXPECT_TRUE(has(error_of(get("/api/nc/table?program=CAM_INTAKE_L1&version=9"), 404), "/api/nc/history"));
  EXPECT_TRUE(has(error_of(get("/api/nc/table?program=CAM_INTAKE_L1&version=0"), 400), "`version`"));
}

TEST_F(HttpPagesTest, APendingTableIsReadWithItsText) {
  fill();
  start();
  Answer a = get("/api/nc/pending/" + std::to_string(pending_id_));
  ASSERT_EQ(a.status, 200) << a.body;
  EXPECT_EQ(a.j["program_text"], "; pending table\r\n");
  EXPECT_EQ(a.j["program"], "CAM_INTAKE_L1");
  EXPECT_EQ(a.j["status"], "pending");
  EXPECT_TRUE(has(error_of(get("/api/nc/pending/99"), 404), "pending"));
}

// Curve tables of CAM_EXHAUST_L1 read by the parser the push reads back with (G1: straight
// lines between the points, so the change per degree is known by hand).
const char* const kExhaustInForce =
    "; CAM_EXHAUST_L1 in force\nCTABDEF(X,C,1,1)\nG1 C0.000 X0.0005\nC360.000 X0.0005\nCTABEND\nM17\n";
// From a seam at C45 (a table's C is read modulo its turn): 0.5 um up to 2.5 um at C135 and
// back by C225, on 0.5 um elsewhere.
const char* const kExhaustPending =
    "; CAM_EXHAUST_L1 pending\nCTABDEF(X,C,1,1)\nG1 C45.000 X0.0005\nC135.000 X0.0025\nC225.000 X0.0005\n"
    "C405.000 X0.0005\nCTABEND\nM17\n";

TEST_F(HttpPagesTest, APendingTableSaysTheVersionItWouldBecomeAndItsChangeFromTheTableInForce) {
  fill();
  std::int64_t id = 0;
  {
    Result<RunStore> store = RunStore::open(db());
    ASSERT_TRUE(store.ok()) << store.error().message;
    NcPush push;
    push.nc_file = "/nc/CAM_EXHAUST_L1.SPF";
    ASSERT_TRUE(store->record_push(ids_[0], push, kExhaustInForce).ok());
    PendingTable pending;
    pending.run_id = ids_[1];
    pending.nc_file = "/nc/CAM_EXHAUST_L1.SPF";
    pending.program_text = kExhaustPending;
    Result<std::int64_t> p = store->add_pending(pending);
    ASSERT_TRUE(p.ok()) << p.error().message;
    id = *p;
  }
  start();
  Answer a = get("/api/nc/pending/" + std::to_string(id));
  ASSERT_EQ(a.status, 200) << a.body;
  EXPECT_EQ(a.j["in_force_version"], 1);
  EXPECT_EQ(a.j["next_version"], 2);
  ASSERT_TRUE(a.j["change"].is_object()) << a.body;
  const json& change = a.j["change"];
  EXPECT_EQ(change["against_version"], 1);
  EXPECT_NEAR(change["max_abs_um"].get<double>(), 2.0, 1e-9);
  EXPECT_EQ(change["at_c_deg"], 135);
  EXPECT_EQ(change["threshold_um"], 0.1);
  // |dX| = 2 um * (C - 45) / 90 rising, 2 um * (225 - C) / 90 falling: over 0.1 um from C50
  // to C135 (86 degrees) and from C136 to C220 (85).
  EXPECT_EQ(change["degrees_over"], 86 + 85);
  EXPECT_EQ(change["degrees"], 360);
  EXPECT_TRUE(a.j["change_problem"].is_null());
}

TEST_F(HttpPagesTest, APendingTableWithoutATableToCompareSaysWhy) {
  fill();
  std::int64_t first = 0;
  {
    Result<RunStore> store = RunStore::open(db());
    ASSERT_TRUE(store.ok()) << store.error().message;
    PendingTable pending;
    pending.run_id = ids_[1];
    pending.nc_file = "/nc/CAM_EXHAUST_L2.SPF";
    pending.program_text = kExhaustPending;
    Result<std::int64_t> p = store->add_pending(pending);
    ASSERT_TRUE(p.ok()) << p.error().message;
    first = *p;
  }
  start();
  Answer none = get("/api/nc/pending/" + std::to_string(first));
  ASSERT_EQ(none.status, 200) << none.body;
  EXPECT_TRUE(none.j["in_force_version"].is_null());
  EXPECT_EQ(none.j["next_version"], 1);
  EXPECT_TRUE(none.j["change"].is_null());
  EXPECT_TRUE(has(none.j["change_problem"].get<std::string>(), "no table of CAM_EXHAUST_L2 is in force"));
  // The fixture's texts are no curve tables: the parser's refusal, not a figure.
  Answer unreadable = get("/api/nc/pending/" + std::to_string(pending_id_));
  ASSERT_EQ(unreadable.status, 200) << unreadable.body;
  EXPECT_EQ(unreadable.j["in_force_version"], 2);
  EXPECT_EQ(unreadable.j["next_version"], 3);
  EXPECT_TRUE(unreadable.j["change"].is_null());
  EXPECT_TRUE(has(unreadable.j["change_problem"].get<std::string>(), "the pending table")) << unreadable.body;
}

TEST_F(HttpPagesTest, ATokenIsCheckedWithoutWritingAnything) {
  fill();
  std::vector<std::string> calls;
  HttpWrites writes;
  writes.reject = [&calls](std::int64_t id, const std::string&, const std::string&) -> Result<json> {
    calls.push_back(std::to_string(id));
    return json{{"rejected", id}};
  };
  start("secret", {}, writes);
  const auto check = [this](const std::string& header) {
    httplib::Headers headers;
    if (!header.empty()) headers.emplace("Authorization", header);
    return answer_of(client_->Get("/api/token", headers));
  };
  Answer good = check("Bearer secret");
  ASSERT_EQ(good.status, 200) << good.body;
  EXPECT_EQ(good.j["token"], "accepted");
  EXPECT_TRUE(has(error_of(check("Bearer wrong"), 401), "not the one configured"));
  EXPECT_TRUE(has(error_of(check(""), 401), "Authorization: Bearer <token>"));
  EXPECT_EQ(header(check("Bearer wrong"), "WWW-Authenticate"), "Bearer realm=\"gaugeloop\"");
  EXPECT_TRUE(has(error_of(answer_of(client_->Get("/api/token?x=1", {{"Authorization", "Bearer secret"}})), 400),
                  "unknown query parameter"));
  EXPECT_TRUE(calls.empty());
  EXPECT_EQ(pending_status(), "pending");
}

TEST_F(HttpPagesTest, ATokenIsRefusedWhenTheApiIsReadOnly) {
  fill();
  start();
  httplib::Headers headers{{"Authorization", "Bearer anything"}};
  EXPECT_TRUE(has(error_of(answer_of(client_->Get("/api/token", headers)), 403), "read-only"));
}

TEST_F(HttpPagesTest, RejectNeedsTheTokenAndLeavesTheTableInForce) {
  fill();
  // As Service::reject decides (without its push slot: nothing pushes here).
  HttpWrites writes;
  writes.reject = [this](std::int64_t id, const std::string& by, const std::string& note) -> Result<json> {
    Result<RunStore> store = RunStore::open(db());
    if (!store) return store.error();
    Result<PendingTable> table = store->load_pending(id);
    if (!table) return table.error();
    if (Status s = store->reject_pending(id, by, note); !s) return s.error();
    return json{{"rejected", id}, {"nc_file", table->nc_file}, {"by", by}};
  };
  start("secret", {}, writes);
  const std::string path = "/api/nc/reject/" + std::to_string(pending_id_);
  const std::string body = R"({"by": "anna", "note": "flank error from a worn wheel"})";
  EXPECT_TRUE(has(error_of(post(path, body), 401), "Authorization: Bearer <token>"));
  EXPECT_TRUE(has(error_of(post(path, body, "wrong"), 401), "not the one configured"));
  EXPECT_EQ(pending_status(), "pending");
  EXPECT_TRUE(has(error_of(post(path, R"({"note": "x"})", "secret"), 400), "`by`"));
  EXPECT_TRUE(has(error_of(post(path, R"({"by": "anna", "why": "x"})", "secret"), 400), "unknown field `why`"));
  // The hook's message as it is (Service::reject's names GET /api/nc/pending: ServiceStateTest).
  EXPECT_TRUE(has(error_of(post("/api/nc/reject/99", body, "secret"), 404), "pending table 99"));
  EXPECT_TRUE(has(error_of(post("/api/nc/reject/x", body, "secret"), 400), "not a number"));
  EXPECT_EQ(pending_status(), "pending");

  Answer ok = post(path, body, "secret");
  ASSERT_EQ(ok.status, 200) << ok.body;
  EXPECT_EQ(ok.j["rejected"], pending_id_);
  EXPECT_EQ(ok.j["nc_file"], "/nc/CAM_INTAKE_L1.SPF");
  EXPECT_EQ(pending_status(), "rejected");
  Answer decided = get("/api/nc/pending/" + std::to_string(pending_id_));
  EXPECT_EQ(decided.j["decided_by"], "anna");
  EXPECT_EQ(decided.j["note"], "flank error from a worn wheel");
  EXPECT_EQ(get("/api/nc/table?program=CAM_INTAKE_L1").j["table_version"], 2) << "the table in force stays";
  EXPECT_EQ(error_of(post(path, body, "secret"), 409).empty(), false) << "no longer pending";
}

TEST_F(HttpPagesTest, RejectGoesThroughTheServicesHook) {
  fill();
  std::vector<std::string> calls;
  HttpWrites writes;
  writes.reject = [&calls](std::int64_t id, const std::string& by, const std::string& note) -> Result<json> {
    calls.push_back(std::to_string(id) + " " + by + " " + note);
    return json{{"rejected", id}};
  };
  start("secret", {}, writes);
  Answer a = post("/api/nc/reject/" + std::to_string(pending_id_), R"({"by": "anna", "note": "worn wheel"})", "secret");
  ASSERT_EQ(a.status, 200) << a.body;
  EXPECT_EQ(calls, std::vector<std::string>{std::to_string(pending_id_) + " anna worn wheel"});
  EXPECT_EQ(pending_status(), "pending") << "the hook decides, not the API";
  EXPECT_TRUE(has(error_of(post("/api/nc/reject/1", R"({"note": "x"})", "secret"), 400), "`by`"));
  EXPECT_EQ(calls.size(), 1u) << "a bad body never reaches the hook";
}

TEST_F(HttpPagesTest, WithoutTheHookRejectIsNotOffered) {
  fill();
  start("secret");
  EXPECT_TRUE(has(error_of(post("/api/nc/reject/" + std::to_string(pending_id_), R"({"by": "anna"})", "secret"), 501),
                  "does not reject"));
  EXPECT_EQ(pending_status(), "pending");
}

TEST_F(HttpPagesTest, RejectIsRefusedWhenTheApiIsReadOnly) {
  fill();
  start();
  EXPECT_TRUE(
      has(error_of(post("/api/nc/reject/" + std::to_string(pending_id_), R"({"by": "anna"})"), 403), "read-only"));
  EXPECT_EQ(pending_status(), "pending");
}

// A preview as the service answers it, its page one value per degree.
NewProgramPreview sample_preview() {
  NewProgramPreview p;
  p.body = json{{"part", "intake_flat"}, {"lobe", 1}, {"table", {{"blocks", 73}}}};
  p.page.title = "New program CAM_INTAKE_L1: intake_flat lobe 1";
  for (int c = 0; c < 360; ++c) {
    const double u = c * M_PI / 180.0;
    p.page.x_mm.push_back(std::sin(u));
    p.page.dx_mm_per_deg.push_back(std::cos(u));
    p.page.d2x_mm_per_deg2.push_back(-std::sin(u));
    p.page.c_speed_rpm.push_back(60.0);
    p.page.grinding_point_speed_mm_per_min.push_back(8000.0);
    p.page.command_error_um.push_back(0.1);
  }
  return p;
}

TEST_F(HttpPagesTest, ANewProgramIsPreviewedWithoutTheTokenAndWrittenWithIt) {
  std::vector<std::string> previews;
  std::vector<std::string> written;
  HttpStatus status;
  status.program_preview = [&previews](const std::string& part, int lobe) -> Result<NewProgramPreview> {
    previews.push_back(part + " " + std::to_string(lobe));
    if (part != "intake_flat") return make_error(ErrorCode::kNotFound, "no part " + part + " lobe 1 is configured");
    return sample_preview();
  };
  HttpWrites writes;
  writes.new_program = [&written](const std::string& part, int lobe, const std::string& by,
                                  bool replace) -> Result<json> {
    written.push_back(part + " " + std::to_string(lobe) + " " + by + (replace ? " replace" : ""));
    return json{{"table_version", 1}};
  };
  start("secret", status, writes);

  Answer preview = get("/api/nc/new?part=intake_flat&lobe=1");
  ASSERT_EQ(preview.status, 200) << preview.body;
  EXPECT_EQ(preview.j["table"]["blocks"], 73);
  Answer plot = get("/api/nc/new/plot.svg?part=intake_flat&lobe=1");
  ASSERT_EQ(plot.status, 200) << plot.body;
  EXPECT_EQ(plot.content_type, "image/svg+xml");
  EXPECT_TRUE(has(plot.body, "<svg")) << plot.body.substr(0, 200);
  EXPECT_EQ(previews, (std::vector<std::string>{"intake_flat 1", "intake_flat 1"}));
  EXPECT_TRUE(has(error_of(get("/api/nc/new?part=exhaust&lobe=1"), 404), "no part exhaust"));
  EXPECT_TRUE(has(error_of(get("/api/nc/new?lobe=1"), 400), "give `part` and `lobe`"));
  EXPECT_TRUE(has(error_of(get("/api/nc/new?part=intake_flat&lobe=0"), 400), "`lobe`"));
  EXPECT_TRUE(has(error_of(get("/api/nc/new?part=intake_flat&lobe=1&pin=2"), 400), "unknown query parameter `pin`"));
  EXPECT_EQ(previews.size(), 3u) << "a bad query never reaches the hook";

  const std::string body = R"({"part": "intake_flat", "lobe": 1, "by": "anna"})";
  EXPECT_TRUE(has(error_of(post("/api/nc/new", body), 401), "Authorization: Bearer <token>"));
  EXPECT_TRUE(has(error_of(post("/api/nc/new", R"({"part": "intake_flat", "lobe": 1})", "secret"), 400), "`by`"));
  EXPECT_TRUE(has(
      error_of(post("/api/nc/new", R"({"part": "intake_flat", "lobe": 1, "by": "anna", "replace": "yes"})", "secret"),
               400),
      "`replace` must be true or false"));
  EXPECT_TRUE(written.empty()) << "nothing written without the token or with a bad body";
  ASSERT_EQ(post("/api/nc/new", body, "secret").status, 200);
  Answer replaced =
      post("/api/nc/new", R"({"part": "intake_flat", "lobe": 1, "by": "anna", "replace": true})", "secret");
  ASSERT_EQ(replaced.status, 200) << replaced.body;
  EXPECT_EQ(replaced.j["table_version"], 1);
  EXPECT_EQ(written, (std::vector<std::string>{"intake_flat 1 anna", "intake_flat 1 anna replace"}));
}

TEST_F(HttpPagesTest, WithoutTheHooksNewProgramsAreNotOffered) {
  start("secret");
  EXPECT_TRUE(has(error_of(get("/api/nc/new?part=intake_flat&lobe=1"), 501), "does not preview"));
  EXPECT_TRUE(has(error_of(get("/api/nc/new/plot.svg?part=intake_flat&lobe=1"), 501), "does not preview"));
  EXPECT_TRUE(has(error_of(post("/api/nc/new", R"({"part": "intake_flat", "lobe": 1, "by": "anna"})", "secret"), 501),
                  "does not write new programs"));
}

// Intake lobe 1 at 0 deg (the datum) and lobe 2 at 110 deg, +-0.5 deg.
ShaftLayout sample_shaft(const std::string& name) {
  ShaftLayout shaft;
  shaft.name = name;
  shaft.index_tolerance_deg = 0.5;
  shaft.lobes = {ShaftLobe{1, "intake_flat", "intake_flat.toml", 0.0},
                 ShaftLobe{2, "intake_flat", "intake_l2.toml", 110.0}};
  return shaft;
}

TEST_F(HttpPagesTest, AShaftRecordGivesEachLobesNewestRunAndItsIndexError) {
  fill();
  HttpStatus status;
  status.shafts = [] { return std::vector<ShaftLayout>{sample_shaft("sample camshaft")}; };
  start("", status);
  EXPECT_EQ(get("/api/health").j["shafts"], json::array({"sample camshaft"}));
  Answer a = get("/api/shaft?serial=S-7");
  ASSERT_EQ(a.status, 200) << a.body;
  EXPECT_EQ(a.j["shaft"], "sample camshaft");
  EXPECT_EQ(a.j["serial"], "S-7");
  ASSERT_EQ(a.j["lobes"].size(), 2u) << a.body;
  EXPECT_EQ(a.j["lobes"][0]["run_id"], ids_[1]) << "the newest run of lobe 1";
  // sample_run: c_offset 10 deg, phase 0.25 deg: the nose stands at C 10.25 deg, nominal 0.
  EXPECT_NEAR(a.j["lobes"][0]["index_error_deg"].get<double>(), 10.25, 1e-9) << a.body;
  EXPECT_EQ(a.j["lobes"][0]["index_verdict"], "out");
  EXPECT_EQ(a.j["lobes"][1]["verdict"], "not_measured");
  EXPECT_TRUE(a.j["lobes"][1]["run_id"].is_null());
  EXPECT_EQ(a.j["verdict"], "out");
  EXPECT_TRUE(has(error_of(get("/api/shaft"), 400), "give its serial"));
  EXPECT_TRUE(has(error_of(get("/api/shaft?serial=S-7&shaft=other"), 404), "the shafts are sample camshaft"));
  Answer none = get("/api/shaft?serial=S-8");
  EXPECT_EQ(none.status, 200) << "one shaft: its record, nothing measured";
  EXPECT_EQ(none.j["verdict"], "incomplete");
}

TEST_F(HttpPagesTest, OfSeveralShaftsTheOneTheSerialWasMeasuredOnIsChosen) {
  fill();
  HttpStatus status;
  status.shafts = [] {
    ShaftLayout other = sample_shaft("exhaust shaft");
    for (ShaftLobe& l : other.lobes) l.part = "exhaust_roller";
    return std::vector<ShaftLayout>{other, sample_shaft("intake shaft")};
  };
  start("", status);
  EXPECT_EQ(get("/api/shaft?serial=S-7").j["shaft"], "intake shaft");
  EXPECT_EQ(get("/api/shaft?serial=S-7&shaft=exhaust%20shaft").j["shaft"], "exhaust shaft");
  EXPECT_TRUE(has(error_of(get("/api/shaft?serial=S-8"), 404), "no lobe of the shafts exhaust shaft, intake shaft"));
}

TEST_F(HttpPagesTest, WithoutShaftFilesTheShaftRecordSaysWhereToLook) {
  fill();
  start();
  EXPECT_EQ(get("/api/health").j["shafts"], json::array());
  EXPECT_TRUE(has(error_of(get("/api/shaft?serial=S-7"), 404), "knows no shaft file"));
}

}  // namespace
}  // namespace gaugeloop

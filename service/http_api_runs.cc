// The HTTP API's reads of runs, gear runs, trends, events and shafts, their pictures and
// documents, and the measurement trigger.
#include <httplib.h>

#include <optional>
#include <string>
#include <vector>

#include "core/part_temperature.h"
#include "report/cam_report.h"
#include "report/gear_report.h"
#include "report/run_json.h"
#include "report/svg_plot.h"
#include "service/http_api_impl.h"

namespace gaugeloop {

using namespace http_detail;

void HttpApi::Impl::list_runs(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q =
      Query::of(req, {"part", "lobe", "machine", "serial", "since", "until", "status", "verdict", "limit"});
  if (!q) return send_error(res, q.error());
  Result<RunQuery> rq = run_query(*q, 50);
  if (!rq) return send_error(res, rq.error());
  rq->serial = q->text("serial");  // matched exactly
  Result<std::string> st = q->choice("status", {"measured", "pushed"});
  if (!st) return send_error(res, st.error());
  rq->status = *st;
  Result<std::string> verdict = q->choice("verdict", {"in", "out", "not_judged"});
  if (!verdict) return send_error(res, verdict.error());
  if (!verdict->empty()) rq->verdict = verdict_from_name(*verdict);
  with_history(res, [&](const RunHistory& history) { return history.list_runs(*rq); });
}

void HttpApi::Impl::list_gear_runs(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {"part", "machine", "serial", "since", "until", "verdict", "limit"});
  if (!q) return send_error(res, q.error());
  Result<RunQuery> rq = run_query(*q, 50);
  if (!rq) return send_error(res, rq.error());
  GearRunQuery gq;
  gq.part = rq->part;
  gq.machine = rq->machine;
  gq.serial = q->text("serial");
  gq.limit = rq->limit;
  gq.since_utc = rq->since_utc;
  gq.until_utc = rq->until_utc;
  Result<std::string> verdict = q->choice("verdict", {"in", "out", "not_judged"});
  if (!verdict) return send_error(res, verdict.error());
  if (!verdict->empty()) gq.verdict = verdict_from_name(*verdict);
  with_store(res, [&](RunStore& store) -> Result<json> {
    Result<std::vector<StoredGearRun>> runs = store.list_gear_runs(gq);
    if (!runs) return runs.error();
    json out = json::array();
    for (const StoredGearRun& g : *runs) out.push_back(gear_run_json(g, false));
    return out;
  });
}

void HttpApi::Impl::gear_run_report(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {});
  if (!q) return send_error(res, q.error());
  Result<std::int64_t> id = path_id(req.matches[1], "gear run id");
  if (!id) return send_error(res, id.error());
  Result<StorePool::Lease> store = stores.acquire();
  if (!store) return send_error(res, store.error());
  Result<StoredGearRun> run = (*store)->load_gear_run(*id);
  if (!run) return fail_with_store(res, *store, run.error());
  const std::string name = "gear_run" + std::to_string(*id) + ".pdf";
  Result<std::string> pdf = file_written_by([&](const fs::path& out) { return write_gear_report(*run, out); }, name);
  if (!pdf) return send_error(res, pdf.error());
  res.status = 200;
  res.set_header("Content-Disposition", "inline; filename=\"" + name + "\"");
  res.set_content(std::move(*pdf), "application/pdf");
}

void HttpApi::Impl::show_gear_run(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {});
  if (!q) return send_error(res, q.error());
  Result<std::int64_t> id = path_id(req.matches[1], "gear run id");
  if (!id) return send_error(res, id.error());
  with_store(res, [&](RunStore& store) -> Result<json> {
    Result<StoredGearRun> run = store.load_gear_run(*id);
    if (!run && run.error().code == ErrorCode::kNotFound) {
      return make_error(ErrorCode::kNotFound, run.error().message + "; GET /api/gear-runs lists the ids");
    }
    if (!run) return run.error();
    return gear_run_json(*run, true);
  });
}

Result<StoredRun> HttpApi::Impl::load_run(RunStore& store, const std::string& id_text) {
  Result<std::int64_t> id = path_id(id_text, "run id");
  if (!id) return id.error();
  Result<StoredRun> run = store.load_run(*id);
  if (!run && run.error().code == ErrorCode::kNotFound) {
    return make_error(ErrorCode::kNotFound, run.error().message + "; GET /api/runs lists the ids");
  }
  return run;
}

void HttpApi::Impl::show_run(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {});
  if (!q) return send_error(res, q.error());
  with_store(res, [&](RunStore& store) -> Result<json> {
    Result<StoredRun> run = load_run(store, req.matches[1]);
    if (!run) return run.error();
    return run_detail_json(*run);
  });
}

void HttpApi::Impl::export_run(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {"comments"});
  if (!q) return send_error(res, q.error());
  Result<bool> comments = q->flag("comments");
  if (!comments) return send_error(res, comments.error());
  Result<StorePool::Lease> store = stores.acquire();
  if (!store) return send_error(res, store.error());
  Result<StoredRun> run = load_run(**store, req.matches[1]);
  if (!run) return fail_with_store(res, *store, run.error());
  res.status = 200;
  res.set_header("Content-Disposition", "inline; filename=\"run" + std::to_string(run->summary.id) + ".csv\"");
  res.set_content(run_csv(*run, *comments), "text/csv; charset=utf-8");
}

void HttpApi::Impl::trend(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {"part", "lobe", "machine", "since", "until", "limit"});
  if (!q) return send_error(res, q.error());
  Result<RunQuery> rq = run_query(*q, kTrendDefaultRuns);
  if (!rq) return send_error(res, rq.error());
  if (rq->part.empty() || rq->lobe == 0) {
    return send_error(res, 400, "a trend is of one lobe: give both `part` and `lobe`, e.g. ?part=intake_flat&lobe=1");
  }
  with_history(res, [&](const RunHistory& history) { return history.trend(*rq); });
}

void HttpApi::Impl::events(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {"kind", "machine", "part", "since", "until", "limit"});
  if (!q) return send_error(res, q.error());
  EventQuery eq;
  Result<std::string> kind = q->choice("kind", {"fault", "refusal", "info"});
  if (!kind) return send_error(res, kind.error());
  if (*kind == "fault") eq.kind = EventKind::kFault;
  if (*kind == "refusal") eq.kind = EventKind::kRefusal;
  if (*kind == "info") eq.kind = EventKind::kInfo;
  eq.machine = q->text("machine");
  eq.part = q->text("part");
  Result<int> limit = q->integer("limit", 50, 1, kMaxLimit);
  if (!limit) return send_error(res, limit.error());
  eq.limit = *limit;
  Result<std::string> since = q->time("since", false);
  if (!since) return send_error(res, since.error());
  eq.since_utc = *since;
  Result<std::string> until = q->time("until", true);
  if (!until) return send_error(res, until.error());
  eq.until_utc = *until;
  with_store(res, [&](RunStore& store) -> Result<json> {
    Result<std::vector<StoredEvent>> events = store.list_events(eq);
    if (!events) return events.error();
    json out = json::array();
    for (const StoredEvent& e : *events) out.push_back(event_json(e));
    return out;
  });
}

void HttpApi::Impl::shaft(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {"serial", "shaft"});
  if (!q) return send_error(res, q.error());
  const std::string serial = q->text("serial");
  if (serial.empty())
    return send_error(res, 400, "a shaft record is of one shaft: give its serial, e.g. ?serial=CS-0042");
  const std::vector<ShaftLayout> layouts = status.shafts ? status.shafts() : std::vector<ShaftLayout>{};
  if (layouts.empty()) {
    return send_error(res, 404,
                      "this service knows no shaft file, so it gives no index errors; GET /api/runs?serial=" + serial +
                          " lists the lobes measured, `gaugeloop runs shaft --shaft FILE` gives the record");
  }
  std::string names;
  for (const ShaftLayout& l : layouts) names += (names.empty() ? "" : ", ") + l.name;
  std::vector<const ShaftLayout*> named;
  for (const ShaftLayout& l : layouts) {
    if (q->text("shaft").empty() || l.name == q->text("shaft")) named.push_back(&l);
  }
  if (named.empty()) {
    return send_error(res, 404, "no shaft '" + q->text("shaft") + "' is known; the shafts are " + names);
  }
  with_store(res, [&](RunStore& store) -> Result<json> {
    std::vector<ShaftRecord> measured;
    for (const ShaftLayout* layout : named) {
      Result<ShaftRecord> record = load_shaft_record(store, *layout, serial);
      if (!record) return record.error();
      if (named.size() == 1) return shaft_record_json(*record);  // the one asked for, measured or not
      if (std::any_of(record->lobes.begin(), record->lobes.end(),
                      [](const ShaftLobeRecord& l) { return l.run.has_value(); })) {
        measured.push_back(std::move(*record));
      }
    }
    if (measured.size() == 1) return shaft_record_json(measured.front());
    if (measured.empty()) {
      return make_error(ErrorCode::kNotFound, "no lobe of the shafts " + names + " was measured with serial " + serial);
    }
    std::string which;
    for (const ShaftRecord& r : measured) which += (which.empty() ? "" : ", ") + r.layout.name;
    return bad_request("serial " + serial + " has runs on several shafts (" + which + "): name one with ?shaft=NAME");
  });
}

std::optional<StoredRun> HttpApi::Impl::path_run(const httplib::Request& req, httplib::Response& res,
                                                 std::vector<std::string> known) {
  Result<Query> q = Query::of(req, std::move(known));
  if (!q) {
    send_error(res, q.error());
    return std::nullopt;
  }
  Result<StorePool::Lease> store = stores.acquire();
  if (!store) {
    send_error(res, store.error());
    return std::nullopt;
  }
  Result<StoredRun> run = load_run(**store, req.matches[1]);
  if (!run) {
    fail_with_store(res, *store, run.error());
    return std::nullopt;
  }
  return std::move(*run);
}

void HttpApi::Impl::run_plot(const httplib::Request& req, httplib::Response& res) {
  // ?layout=narrow: the panels stacked, for a phone held upright.
  const std::string layout = req.has_param("layout") ? req.get_param_value("layout") : "wide";
  if (layout != "wide" && layout != "narrow") {
    send_error(res, bad_request("layout `" + layout + "`: give wide or narrow"));
    return;
  }
  const std::optional<StoredRun> run = path_run(req, res, {"layout"});
  if (!run) return;
  res.status = 200;
  res.set_content(
      render_error_plot_svg(run_error_plot(*run), layout == "narrow" ? PlotShape::kNarrow : PlotShape::kWide),
      "image/svg+xml");
}

void HttpApi::Impl::run_report(const httplib::Request& req, httplib::Response& res) {
  const std::optional<StoredRun> run = path_run(req, res);
  if (!run) return;
  const std::string name = "run" + std::to_string(run->summary.id) + ".pdf";
  Result<std::string> pdf = file_written_by([&](const fs::path& out) { return write_cam_report(*run, out); }, name);
  if (!pdf) return send_error(res, pdf.error());
  res.status = 200;
  res.set_header("Content-Disposition", "inline; filename=\"" + name + "\"");
  res.set_content(std::move(*pdf), "application/pdf");
}

void HttpApi::Impl::trend_plot(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {"part", "lobe", "machine", "since", "until", "limit", "key"});
  if (!q) return send_error(res, q.error());
  Result<RunQuery> rq = run_query(*q, kTrendDefaultRuns);
  if (!rq) return send_error(res, rq.error());
  if (rq->part.empty() || rq->lobe == 0) {
    return send_error(
        res, 400, "a trend is of one lobe: give both `part` and `lobe`, e.g. ?part=intake_flat&lobe=1&key=lift_error");
  }
  const std::string key = q->text("key").empty() ? std::string("lift_error") : q->text("key");
  Result<std::vector<RunCharacteristics>> runs =
      read_history([&](const RunHistory& history) { return trend_plot_runs(history, *rq, key); });
  if (!runs) return send_error(res, runs.error());
  if (runs->empty()) {
    return send_error(res, 404,
                      "no runs of " + rq->part + " lobe " + std::to_string(rq->lobe) +
                          " match; GET /api/runs lists which parts and lobes have runs");
  }
  Result<std::string> svg = trend_plot_svg(*runs, key);
  if (!svg) return send_error(res, svg.error());
  res.status = 200;
  res.set_content(std::move(*svg), "image/svg+xml");
}

void HttpApi::Impl::measure(const httplib::Request&, const std::string& text, httplib::Response& res) {
  if (!writes.trigger_measure) return send_error(res, 501, "this service does not take measurement triggers");
  Result<json> body = body_object(
      text, {"part", "lobe", "note", "serial", "operator", "part_temperature_c"},
      R"({"part": "intake_flat", "lobe": 1, "serial": "A123", "operator": "anna", "part_temperature_c": 21.4})");
  if (!body) return send_error(res, body.error());
  Result<std::string> part = string_field(*body, "part", true);
  if (!part) return send_error(res, part.error());
  Result<int> lobe = int_field(*body, "lobe", 1, kMaxLobe);
  if (!lobe) return send_error(res, lobe.error());
  Result<std::string> note = string_field(*body, "note", false);
  if (!note) return send_error(res, note.error());
  // Empty or null: not given. Checked here so a bad one is a 400 before the run is queued.
  Result<std::string> serial = string_field(*body, "serial", false);
  if (!serial) return send_error(res, serial.error());
  if (Status s = check_run_identity("`serial`", *serial); !s) return send_error(res, s.error());
  Result<std::string> operator_name = string_field(*body, "operator", false);
  if (!operator_name) return send_error(res, operator_name.error());
  if (Status s = check_run_identity("`operator`", *operator_name); !s) return send_error(res, s.error());
  Result<std::optional<double>> temperature = number_field(*body, "part_temperature_c");
  if (!temperature) return send_error(res, temperature.error());
  if (*temperature) {
    Result<double> c = checked_part_temperature_c(**temperature, "`part_temperature_c`");
    if (!c) return send_error(res, c.error());
    *temperature = *c;
  }
  answer(res, writes.trigger_measure(*part, *lobe, *note, *serial, *operator_name, *temperature));
}

}  // namespace gaugeloop

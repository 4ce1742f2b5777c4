// The HTTP API's curve tables: the one in force and its history, pending tables and their
// approval, rejection and rollback, and new programs from a part's drawing.
#include <httplib.h>

#include <cmath>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "job/layer_files.h"
#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"
#include "report/program_preview.h"
#include "report/run_json.h"
#include "service/http_api_impl.h"

namespace gaugeloop {

using namespace http_detail;

namespace {

// Program names a client gives, against the NC files the history knows: "CAM_INTAKE_L1",
// "CAM_INTAKE_L1.SPF", or the file's path as recorded.
bool names_file(const std::string& program, const std::string& nc_file) {
  if (program == nc_file) return true;
  std::string name = program;
  if (name.size() > 4 && (name.ends_with(".SPF") || name.ends_with(".spf"))) name.resize(name.size() - 4);
  return fs::path(nc_file).stem().string() == name;
}

std::string program_list(const std::set<std::string>& files) {
  std::string list;
  for (const std::string& f : files) list += (list.empty() ? "" : ", ") + fs::path(f).stem().string();
  return list;
}

// The NC files tables were pushed to (and, with `pending`, those with pending tables).
Result<std::set<std::string>> known_files(const RunStore& store, bool pending) {
  std::set<std::string> files;
  PushQuery pq;
  pq.limit = kAll;
  Result<std::vector<NcPush>> pushes = store.list_pushes(pq);
  if (!pushes) return pushes.error();
  for (const NcPush& p : *pushes) files.insert(p.nc_file);
  if (pending) {
    PendingQuery q;
    q.limit = kAll;
    Result<std::vector<PendingTable>> tables = store.list_pending(q);
    if (!tables) return tables.error();
    for (const PendingTable& t : *tables) files.insert(t.nc_file);
  }
  return files;
}

// The one NC file `program` names; empty `program`: the only file there is.
Result<std::string> resolve_program(const RunStore& store, const std::string& program, bool pending) {
  Result<std::set<std::string>> files = known_files(store, pending);
  if (!files) return files.error();
  if (program.empty()) {
    if (files->size() == 1) return *files->begin();
    if (files->empty()) {
      return make_error(ErrorCode::kNotFound,
                        "no table was pushed yet; the first measurement writes one (POST /api/measure)");
    }
    return bad_request("tables were pushed to several programs (" + program_list(*files) +
                       "): name one with ?program=NAME");
  }
  std::set<std::string> named;
  for (const std::string& f : *files) {
    if (names_file(program, f)) named.insert(f);
  }
  if (named.size() == 1) return *named.begin();
  if (named.empty()) {
    return make_error(ErrorCode::kNotFound, "no table of program '" + program + "' is recorded; " +
                                                (files->empty() ? std::string("no table was pushed yet")
                                                                : "the programs are " + program_list(*files)));
  }
  std::string paths;
  for (const std::string& f : named) paths += (paths.empty() ? "" : ", ") + f;
  return bad_request("program '" + program + "' names several NC files (" + paths +
                     "); give the path as ?program=PATH");
}

// A whole degree of C counts as changed when the two tables' X differ there by more than this:
// one step of X as the tables are written by default (0.0001 mm, CurveTableFormat).
constexpr double kChangeThresholdUm = 0.1;

// What the control interpolates from a table program's points, with the table's axes.
struct TableOnControl {
  ParsedTable parsed;
  TableInterpolant interpolant;
};

Result<TableOnControl> table_on_control(const std::string& text, const std::string& what) {
  Result<ParsedTable> parsed = parse_table_program(text, what);
  if (!parsed) return parsed.error();
  if (parsed->interpolation == Interpolation::kCubicSpline && !parsed->natural_ends) {
    return make_error(ErrorCode::kInvalidInput,
                      what + ": a CSPLINE table without BNAT and ENAT, whose ends gaugeloop does not model");
  }
  Result<TableInterpolant> interpolant = TableInterpolant::of(parsed->points, parsed->interpolation);
  if (!interpolant) return make_error(ErrorCode::kInvalidInput, what + ": " + interpolant.error().message);
  return TableOnControl{std::move(*parsed), std::move(*interpolant)};
}

// How a pending table would move the following axis against the table in force: both read from
// their program texts as the control interpolates them, X (or Y) compared at every whole degree
// of the leading axis, C = 0 .. 359 (a table's C read modulo its turn, as the control reads a
// periodic table). kInvalidInput saying why when either text is no curve table gaugeloop can
// read, or the two tables are of different axes.
Result<json> change_from_in_force(const std::string& pending_text, const std::string& in_force_text,
                                  int in_force_version) {
  Result<TableOnControl> pending = table_on_control(pending_text, "the pending table");
  if (!pending) return pending.error();
  Result<TableOnControl> in_force =
      table_on_control(in_force_text, "version " + std::to_string(in_force_version) + " in force");
  if (!in_force) return in_force.error();
  const ParsedTable& p = pending->parsed;
  const ParsedTable& f = in_force->parsed;
  if (p.following_axis != f.following_axis || p.leading_axis != f.leading_axis) {
    return make_error(ErrorCode::kInvalidInput, "the pending table is of " + p.following_axis + " over " +
                                                    p.leading_axis + ", the table in force of " + f.following_axis +
                                                    " over " + f.leading_axis + ": not comparable degree by degree");
  }
  double max_abs_um = 0.0;
  int at_deg = 0;
  int over = 0;
  for (int deg = 0; deg < 360; ++deg) {
    const double c = static_cast<double>(deg);
    const double dx_um = (pending->interpolant.at(c).x_mm - in_force->interpolant.at(c).x_mm) * 1000.0;
    if (std::abs(dx_um) > max_abs_um) {
      max_abs_um = std::abs(dx_um);
      at_deg = deg;
    }
    // A tolerance far below the threshold: one step of the format is 0.1 um give or take the
    // last bit, and counts as no change.
    if (std::abs(dx_um) > kChangeThresholdUm + 1e-6) ++over;
  }
  return json{{"against_version", in_force_version}, {"max_abs_um", max_abs_um}, {"at_c_deg", at_deg},
              {"threshold_um", kChangeThresholdUm},  {"degrees_over", over},     {"degrees", 360}};
}

}  // namespace

void HttpApi::Impl::nc_table(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {"program", "version"});
  if (!q) return send_error(res, q.error());
  // Any version the history holds (for a diff of two); without `version`, the one in force.
  Result<int> version = q->integer("version", 0, 1, INT_MAX);
  if (!version) return send_error(res, version.error());
  with_store(res, [&](RunStore& store) -> Result<json> {
    Result<std::string> file = resolve_program(store, q->text("program"), false);
    if (!file) return file.error();
    std::optional<NcPush> push;
    if (*version > 0) {
      Result<NcPush> one = store.load_push(*file, *version);
      if (!one) {
        if (one.error().code != ErrorCode::kNotFound) return one.error();
        return make_error(ErrorCode::kNotFound, one.error().message + "; GET /api/nc/history lists the versions");
      }
      push = std::move(*one);
    } else {
      Result<std::optional<NcPush>> last = store.last_push(*file);
      if (!last) return last.error();
      push = std::move(*last);
    }
    if (!push) return make_error(ErrorCode::kNotFound, "no table was pushed to " + *file);
    json out = nc_push_json(*push);
    out["program"] = fs::path(*file).stem().string();
    out["program_text"] = push->program_text ? json(*push->program_text) : json(nullptr);
    // A correction layer: the design table the control adds it to, as it holds it now.
    out["layer"] = nullptr;
    if (push->program_text) {
      Result<std::optional<LayerOnControl>> layer = layer_on_control(*push->program_text, *file);
      if (layer && *layer) {
        const LayerOnControl& l = **layer;
        out["layer"] = {{"design_program", fs::path(l.design_file).stem().string()},
                        {"design_table_number", l.design_table_number},
                        {"design_text", l.problem.empty() ? json(l.design_text) : json(nullptr)},
                        {"design_problem", l.problem.empty() ? json(nullptr) : json(l.problem)}};
      }
    }
    return out;
  });
}

void HttpApi::Impl::nc_history(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {"program", "limit"});
  if (!q) return send_error(res, q.error());
  Result<int> limit = q->integer("limit", 50, 1, kMaxLimit);
  if (!limit) return send_error(res, limit.error());
  with_store(res, [&](RunStore& store) -> Result<json> {
    PushQuery pq;
    pq.limit = *limit;
    if (const std::string program = q->text("program"); !program.empty()) {
      Result<std::string> file = resolve_program(store, program, false);
      if (!file) return file.error();
      pq.nc_file = *file;
    }
    Result<std::vector<NcPush>> pushes = store.list_pushes(pq);
    if (!pushes) return pushes.error();
    json out = json::array();
    for (const NcPush& p : *pushes) out.push_back(nc_push_json(p));
    return out;
  });
}

void HttpApi::Impl::nc_pending(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {"program", "all", "limit"});
  if (!q) return send_error(res, q.error());
  Result<int> limit = q->integer("limit", 50, 1, kMaxLimit);
  if (!limit) return send_error(res, limit.error());
  Result<bool> all = q->flag("all");
  if (!all) return send_error(res, all.error());
  with_store(res, [&](RunStore& store) -> Result<json> {
    PendingQuery pq;
    pq.limit = *limit;
    if (!*all) pq.status = PendingStatus::kPending;
    if (const std::string program = q->text("program"); !program.empty()) {
      Result<std::string> file = resolve_program(store, program, true);
      if (!file) return file.error();
      pq.nc_file = *file;
    }
    Result<std::vector<PendingTable>> tables = store.list_pending(pq);
    if (!tables) return tables.error();
    json out = json::array();
    for (const PendingTable& t : *tables) out.push_back(pending_table_json(t));
    return out;
  });
}

void HttpApi::Impl::pending_table(const httplib::Request& req, httplib::Response& res) {
  Result<Query> q = Query::of(req, {});
  if (!q) return send_error(res, q.error());
  with_store(res, [&](RunStore& store) -> Result<json> {
    Result<std::int64_t> id = path_id(req.matches[1], "pending table id");
    if (!id) return id.error();
    Result<PendingTable> table = store.load_pending(*id);
    if (!table) {
      if (table.error().code != ErrorCode::kNotFound) return table.error();
      return make_error(ErrorCode::kNotFound, table.error().message + "; GET /api/nc/pending?all=true lists the ids");
    }
    json out = pending_table_json(*table);
    out["program"] = fs::path(table->nc_file).stem().string();
    out["program_text"] = table->program_text;
    // What approving it would do: the version it would become if nothing else is pushed first,
    // and its change from the table in force.
    out["next_version"] = nullptr;
    if (table->status == PendingStatus::kPending) {
      Result<int> next = store.next_table_version(table->nc_file);
      if (!next) return next.error();
      out["next_version"] = *next;
    }
    Result<std::optional<NcPush>> in_force = store.last_push(table->nc_file);
    if (!in_force) return in_force.error();
    out["in_force_version"] = *in_force ? json((*in_force)->table_version) : json(nullptr);
    out["change"] = nullptr;
    out["change_problem"] = nullptr;
    if (table->status != PendingStatus::kPending) {
      out["change_problem"] =
          "the table is no longer pending: GET /api/nc/table?version= gives the versions to compare";
    } else if (table->gear_run_id != 0) {
      out["change_problem"] = "a gear's stroke program: it has no curve table over C to compare";
    } else if (!*in_force) {
      out["change_problem"] = "no table of " + out["program"].get<std::string>() + " is in force yet";
    } else if (!(*in_force)->program_text) {
      out["change_problem"] = "the text of version " + std::to_string((*in_force)->table_version) +
                              " in force was not kept (written by an older gaugeloop)";
    } else {
      Result<json> change =
          change_from_in_force(table->program_text, *(*in_force)->program_text, (*in_force)->table_version);
      if (change) {
        out["change"] = std::move(*change);
      } else {
        out["change_problem"] = change.error().message;
      }
    }
    return out;
  });
}

void HttpApi::Impl::decide(const httplib::Request& req, const std::string& text, httplib::Response& res,
                           const Decision& hook, const char* not_offered, const char* example) {
  if (!hook) return send_error(res, 501, not_offered);
  Result<std::int64_t> id = path_id(req.matches[1], "pending table id");
  if (!id) return send_error(res, id.error());
  Result<json> body = body_object(text, {"by", "note"}, example);
  if (!body) return send_error(res, body.error());
  Result<std::string> by = string_field(*body, "by", true);
  if (!by) return send_error(res, by.error());
  Result<std::string> note = string_field(*body, "note", false);
  if (!note) return send_error(res, note.error());
  answer(res, hook(*id, *by, *note));
}

void HttpApi::Impl::approve(const httplib::Request& req, const std::string& text, httplib::Response& res) {
  decide(req, text, res, writes.approve, "this service does not approve tables",
         R"({"by": "anna", "note": "checked the lobe"})");
}

void HttpApi::Impl::reject(const httplib::Request& req, const std::string& text, httplib::Response& res) {
  decide(req, text, res, writes.reject, "this service does not reject tables",
         R"({"by": "anna", "note": "flank error from a worn wheel"})");
}

void HttpApi::Impl::rollback(const httplib::Request&, const std::string& text, httplib::Response& res) {
  if (!writes.rollback) return send_error(res, 501, "this service does not roll tables back");
  Result<json> body =
      body_object(text, {"program", "version", "by"}, R"({"program": "CAM_INTAKE_L1", "version": 3, "by": "anna"})");
  if (!body) return send_error(res, body.error());
  Result<std::string> program = string_field(*body, "program", true);
  if (!program) return send_error(res, program.error());
  Result<int> version = int_field(*body, "version", 1, INT_MAX);
  if (!version) return send_error(res, version.error());
  Result<std::string> by = string_field(*body, "by", true);
  if (!by) return send_error(res, by.error());
  answer(res, writes.rollback(*program, *version, *by));
}

Result<std::pair<std::string, int>> HttpApi::Impl::preview_query(const httplib::Request& req) const {
  Result<Query> q = Query::of(req, {"part", "lobe"});
  if (!q) return q.error();
  Result<int> lobe = q->integer("lobe", 0, 1, kMaxLobe);
  if (!lobe) return lobe.error();
  if (q->text("part").empty() || *lobe == 0) {
    return bad_request(
        "a new program is of one configured part: give `part` and `lobe`, e.g. "
        "?part=intake_flat&lobe=1 (GET /api/health lists the parts)");
  }
  return std::make_pair(q->text("part"), *lobe);
}

Result<NewProgramPreview> HttpApi::Impl::program_preview(const httplib::Request& req) const {
  Result<std::pair<std::string, int>> q = preview_query(req);
  if (!q) return q.error();
  return status.program_preview(q->first, q->second);
}

void HttpApi::Impl::new_program_preview(const httplib::Request& req, httplib::Response& res) {
  if (!status.program_preview) return send_error(res, 501, "this service does not preview new programs");
  Result<NewProgramPreview> p = program_preview(req);
  if (!p) return send_error(res, p.error());
  send_json(res, 200, p->body);
}

void HttpApi::Impl::new_program_plot(const httplib::Request& req, httplib::Response& res) {
  if (!status.program_preview) return send_error(res, 501, "this service does not preview new programs");
  Result<NewProgramPreview> p = program_preview(req);
  if (!p) return send_error(res, p.error());
  Result<std::string> svg =
      file_written_by([&](const fs::path& out) { return write_program_preview(p->page, out); }, "preview.svg");
  if (!svg) return send_error(res, svg.error());
  res.status = 200;
  res.set_content(std::move(*svg), "image/svg+xml");
}

void HttpApi::Impl::new_program(const httplib::Request&, const std::string& text, httplib::Response& res) {
  if (!writes.new_program) return send_error(res, 501, "this service does not write new programs");
  Result<json> body = body_object(text, {"part", "lobe", "by", "replace"},
                                  R"({"part": "intake_flat", "lobe": 1, "by": "anna", "replace": false})");
  if (!body) return send_error(res, body.error());
  Result<std::string> part = string_field(*body, "part", true);
  if (!part) return send_error(res, part.error());
  Result<int> lobe = int_field(*body, "lobe", 1, kMaxLobe);
  if (!lobe) return send_error(res, lobe.error());
  Result<std::string> by = string_field(*body, "by", true);
  if (!by) return send_error(res, by.error());
  Result<bool> replace = bool_field(*body, "replace");
  if (!replace) return send_error(res, replace.error());
  answer(res, writes.new_program(*part, *lobe, *by, *replace));
}

}  // namespace gaugeloop

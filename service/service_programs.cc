// The service's first programs: a configured part's new program previewed and written, as
// `gaugeloop nc new` does (job/nc_new.h), for the HTTP API and the pages.
#include <spdlog/spdlog.h>

#include <string>
#include <utility>

#include "job/nc_new.h"
#include "service/service.h"

namespace gaugeloop {
namespace {

using nlohmann::json;

json table_json(const CurveTable& t) {
  return {{"writer", t.writer},
          {"interpolation", std::string(interpolation_name(t.interpolation))},
          {"blocks", t.block_count()},
          {"seam_c_deg", t.points.front().c_deg},
          {"command_error_um", t.error.max_abs_um},
          {"at_c_deg", t.error.at_c_deg}};
}

// The candidates the default choice weighed for one axis, the chosen one marked.
void add_choices(json& out, const char* axis, const std::vector<TableCandidate>& candidates, const CurveTable& chosen) {
  for (const TableCandidate& c : candidates) {
    json row = {{"axis", axis}, {"writer", c.writer}};
    if (!c.table) {
      row["refused"] = c.refused;
    } else {
      row.update(table_json(*c.table));
      row["chosen"] = c.table->writer == chosen.writer && c.table->block_count() == chosen.block_count();
    }
    out.push_back(std::move(row));
  }
}

// The profile per whole degree of C, one array per quantity (as the CSV of `nc new --csv`).
json profile_json(const ProgramPreview& p) {
  json out = json::object();
  auto column = [&](const char* name, auto value) {
    json a = json::array();
    for (const PreviewRow& r : p.rows) a.push_back(value(r));
    out[name] = std::move(a);
  };
  column("c_deg", [](const PreviewRow& r) { return r.c_deg; });
  column("x_mm", [](const PreviewRow& r) { return r.x_mm; });
  column("dx_mm_per_deg", [](const PreviewRow& r) { return r.dx_mm_per_deg; });
  column("d2x_mm_per_deg2", [](const PreviewRow& r) { return r.d2x_mm_per_deg2; });
  if (p.built.y_table) column("y_mm", [](const PreviewRow& r) { return r.y_mm.value_or(0.0); });
  column("c_speed_rpm", [](const PreviewRow& r) { return r.c_speed_rpm; });
  column("grinding_point_speed_mm_per_min", [](const PreviewRow& r) { return r.grinding_point_speed_mm_per_min; });
  column("x_nc_mm", [](const PreviewRow& r) { return r.x_nc_mm; });
  column("command_error_um", [](const PreviewRow& r) { return r.command_error_um; });
  if (p.built.y_table) {
    column("y_command_error_um", [](const PreviewRow& r) { return r.y_command_error_um.value_or(0.0); });
  }
  return out;
}

json passes_json(const InfeedPlan& plan) {
  json out = json::array();
  for (const InfeedPass& pass : plan.passes) {
    out.push_back({{"name", pass.name}, {"turns", pass.turns}, {"infeed_mm", pass.infeed_mm}});
  }
  return out;
}

// The preview as GET /api/nc/new answers it (docs/http_api.md); without the profile per degree
// for the answer of a write.
json preview_json(const ProgramPreview& p, const JobSettings& s, bool with_profile = true) {
  const BuiltTable& b = p.built;
  json choices = json::array();
  add_choices(choices, "X", p.x_candidates, b.table);
  if (b.y_table) add_choices(choices, "Y", p.y_candidates, *b.y_table);
  json speed = nullptr;
  if (b.speed) {
    speed = {{"feed_blocks", b.speed->profile.block_count()},
             {"speed_error_percent", b.speed->profile.error.max_speed_error_percent},
             {"turn_time_s", b.speed->plan.cycle_time_s},
             {"constant_turn_time_s", b.speed->plan.constant_cycle_time_s},
             {"base_speed_rpm", s.speed->base_speed_rpm}};
  }
  return {{"part", s.part.name},
          {"lobe", s.part.lobe},
          {"kind", s.pin ? std::string(s.pin->mode == PinMode::kCXY ? "pin C-X-Y" : "pin C-X") : "lobe"},
          {"program", s.nc_program},
          {"nc_file", std::filesystem::absolute(s.nc_dir / (s.nc_program + ".SPF")).lexically_normal().string()},
          {"command_error_bound_um", s.table_choice.bound_um},
          {"x_increments_per_mm", s.table_format.x_increments_per_mm},
          {"table", table_json(b.table)},
          {"y_table", b.y_table ? table_json(*b.y_table) : json(nullptr)},
          {"choices", std::move(choices)},
          {"speed_program", std::move(speed)},
          {"work_speed_rpm", b.speed ? json(nullptr) : json(p.work_speed_rpm)},
          {"stock_mm", s.cycle.stock_mm},
          {"air_gap_mm", s.cycle.air_gap_mm},
          {"start_offset_mm", p.infeed.start_offset_mm},
          {"passes", passes_json(p.infeed)},
          {"turns", p.infeed.turns()},
          {"turn_time_s", p.turn_time_s},
          {"cycle_time_s", p.cycle_time_s},
          {"profile", with_profile ? profile_json(p) : json(nullptr)}};
}

}  // namespace

Result<NewProgramPreview> Service::preview_program(const std::string& part_name, int lobe) {
  const std::shared_ptr<const ServiceConfig> c = config();
  Result<const ServicePart*> part = find_part(*c, part_name, lobe);
  if (!part) return part.error();
  std::lock_guard<std::mutex> lock(preview_mutex_);
  if (last_preview_ && last_preview_->config == c && last_preview_->part == part_name && last_preview_->lobe == lobe) {
    return last_preview_->preview;
  }
  const JobSettings js = job_for(*c, **part);
  Result<ProgramPreview> p = preview_new_program(js);
  if (!p) return p.error();
  NewProgramPreview out{preview_json(*p, js), preview_page(*p, js)};
  last_preview_ = CachedPreview{c, part_name, lobe, out};
  return out;
}

Result<json> Service::new_program(const std::string& part_name, int lobe, const std::string& by, bool replace) {
  const Result<RunReservation> held = wait_and_reserve();  // one push at a time
  if (!held) return held.error();
  const std::shared_ptr<const ServiceConfig> c = config();
  Result<const ServicePart*> part = find_part(*c, part_name, lobe);
  if (!part) return part.error();
  const JobSettings js = job_for(*c, **part);
  NewProgramOptions options;
  options.replace = replace;
  options.by = by;
  options.from_file = "part " + part_name + " of " + c->source.string();
  Result<NewProgramReport> r = write_new_program(js, options);
  if (!r) {
    spdlog::warn("new program for part {} lobe {} not written: {}", part_name, lobe, r.error().message);
    return r.error();
  }
  spdlog::info("new program by {}: {} version {} written from the drawing of part {} lobe {}", by, r->nc_file.string(),
               r->table_version, part_name, lobe);
  tell_plant();
  json files = json::array();
  for (const std::filesystem::path& f : r->files) files.push_back(f.string());
  json out = preview_json(r->preview, js, /*with_profile=*/false);  // the preview has it
  out.erase("profile");
  out["table_version"] = r->table_version;
  out["files"] = std::move(files);
  return out;
}

}  // namespace gaugeloop

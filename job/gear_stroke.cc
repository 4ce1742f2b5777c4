// The gear's stroke program, written and read back.
#include "job/gear_stroke.h"

#include <cmath>

#include "core/atomic_file.h"
#include "core/number_text.h"
#include "core/text_file.h"
#include "core/utc_time.h"
#include "nc_out/stroke_program.h"

namespace gaugeloop {

Result<GearStrokeReport> write_gear_stroke(const GearPart& part, const StrokeAxisErrors& errors,
                                           const GearStrokeSettings& s) {
  if (Status v = validate(part); !v) return v.error();
  Result<std::vector<StrokeSimPoint>> points = stroke_sim_points(part, gear_coupling(part), errors);
  if (!points) return points.error();
  return push_gear_stroke(part, std::move(*points), errors.source, s);
}

Result<GearStrokeReport> push_gear_stroke(const GearPart& part, std::vector<StrokeSimPoint> points,
                                          const std::string& source, const GearStrokeSettings& s) {
  if (Status v = validate(part); !v) return v.error();
  GearStrokeReport r;
  r.coupling = gear_coupling(part);
  r.points = std::move(points);
  const GearCoupling& k = r.coupling;
  // B's factor as the whole ratio the gearbox needs: -h_w starts over teeth (S_BC exactly).
  GearboxFactors factors;
  factors.b_numerator = -hand_sign(part.worm.hand) * part.worm.starts;
  factors.b_denominator = part.gear.teeth;
  factors.z_deg_per_mm = k.s_zc_deg_per_mm;
  factors.y_deg_per_mm = k.s_yc_deg_per_mm;
  r.coupling_lines = render_gearbox_coupling(factors);
  std::vector<StrokeProgramPoint> program_points;
  for (const StrokeSimPoint& p : r.points) {
    program_points.push_back({p.z_mm, p.sim_deg});
    r.sim_max_abs_deg = std::max(r.sim_max_abs_deg, std::abs(s.format.round_sim_deg(p.sim_deg)));
  }
  const std::map<std::string, std::string> header{
      {"part", s.part_name},
      {"program", s.program_name},
      {"run_id", "0"},
      {"table_version", "0"},
      {"created_utc", utc_now()},
      {"source", source},
      {"s_bc", std::to_string(factors.b_numerator) + "/" + std::to_string(factors.b_denominator)},
      {"s_zc_deg_per_mm", format_fixed(k.s_zc_deg_per_mm, 12)},
      {"s_yc_deg_per_mm", format_fixed(k.s_yc_deg_per_mm, 12)},
  };
  Result<std::string> text = render_stroke_program(s.program_name, header, program_points, s.feed_mm_per_min, s.format);
  if (!text) return text.error();
  // What the control would read (or the approval will push): parsed, checksummed, every point
  // as written. kIo naming `name` and the line otherwise.
  auto check_reads_back = [&](const std::string& back, const std::string& name) -> Status {
    Result<ParsedStrokeProgram> parsed = parse_stroke_program(back, name);
    if (!parsed) return make_error(ErrorCode::kIo, name + " does not read back: " + parsed.error().message);
    for (std::size_t i = 0; i < program_points.size(); ++i) {
      const StrokeProgramPoint& a = parsed->points[i];
      if (a.z_mm != s.format.round_z_mm(program_points[i].z_mm) ||
          a.sim_deg != s.format.round_sim_deg(program_points[i].sim_deg)) {
        return make_error(ErrorCode::kIo, name + ":" + std::to_string(parsed->point_lines[i]) + ": reads back Z" +
                                              format_fixed(a.z_mm, 4) + " SIM1=" + format_fixed(a.sim_deg, 6) +
                                              ", not what was written");
      }
    }
    return {};
  };
  TableFacts facts;
  facts.interpolation = "stroke";
  facts.point_count = static_cast<int>(program_points.size());
  facts.block_count = static_cast<int>(program_points.size());
  if (s.store != nullptr && s.require_approval) {
    if (s.gear_run_id == 0) {
      return make_error(ErrorCode::kInvalidInput,
                        "a stroke kept for approval names the gear run it was corrected from; none was given");
    }
    // Checked before it is kept: a pending program is one the approval can push as it is.
    if (Status c = check_reads_back(*text, "the stroke program for " + s.nc_file.string()); !c) return c.error();
    PendingTable pending;
    pending.gear_run_id = s.gear_run_id;
    pending.nc_file = s.nc_file.string();
    pending.program_text = *text;
    pending.reason = "approval required";
    pending.table = facts;
    Result<std::int64_t> id = s.store->add_pending(pending);
    if (!id) return id.error();
    r.pending_id = *id;
    return r;
  }
  if (s.store != nullptr) {
    PushFacts push;
    push.reason = "stroke from " + source;
    push.table = facts;
    PushOptions options;
    options.overwrite_edited = s.overwrite_edited;
    options.main = s.main;
    const std::string& program = *text;
    Result<PushCompletion> pushed = push_program(
        *s.store, s.nc_file, push, [&program](int version) { return with_table_version(program, version); }, options);
    if (!pushed) return pushed.error();
    r.version = pushed->table_version;
    r.written = s.nc_file;
  } else {
    if (Status w = write_file_atomically(s.out_file, *text); !w) return w.error();
    r.written = s.out_file;
  }
  Result<std::string> back = read_regular_file(r.written, "stroke program");
  if (!back) return back.error();
  if (Status c = check_reads_back(*back, r.written.string()); !c) return c.error();
  return r;
}

Result<StrokeInForce> stroke_in_force(const RunStore& store, const std::filesystem::path& nc_file,
                                      const std::string& advice) {
  Result<std::optional<NcPush>> last = store.last_push(nc_file.string());
  if (!last) return last.error();
  if (!*last || !(**last).program_text || !is_stroke_program(*(**last).program_text)) {
    return make_error(ErrorCode::kNotFound,
                      nc_file.string() + ": no stroke program was pushed there, so there is none in force; " + advice);
  }
  Result<ParsedStrokeProgram> p = parse_stroke_program(*(**last).program_text, nc_file.string());
  if (!p) return p.error();
  StrokeInForce out;
  out.version = (**last).table_version;
  for (const StrokeProgramPoint& q : p->points) {
    StrokeSimPoint point;
    point.z_mm = q.z_mm;
    point.sim_deg = q.sim_deg;
    out.points.push_back(point);
  }
  return out;
}

Result<GearCorrection> correct_gear_stroke(const GearPart& part, const std::vector<LeadTrace>& traces,
                                           const std::string& source, const GearStrokeSettings& s) {
  if (s.store == nullptr) {
    return make_error(ErrorCode::kInvalidInput, "a stroke is corrected from the one in force: it needs the history");
  }
  if (Status v = validate(part); !v) return v.error();
  Result<StrokeInForce> in_force = stroke_in_force(
      *s.store, s.nc_file, "push the first with `gaugeloop gear stroke` (an axis error table, or one of zeros)");
  if (!in_force) return in_force.error();
  GearCorrection c;
  c.from_version = in_force->version;
  std::vector<double> z;
  for (const StrokeSimPoint& p : in_force->points) z.push_back(p.z_mm);
  Result<MeshIdentification> m = identify_mesh_error(traces, z, base_radius_mm(part.gear));
  if (!m) return m.error();
  std::vector<StrokeSimPoint> next;
  for (std::size_t k = 0; k < z.size(); ++k) {
    StrokeSimPoint p;
    p.z_mm = z[k];
    p.sim_deg = in_force->points[k].sim_deg - m->mesh_deg[k];
    next.push_back(p);
  }
  Result<GearStrokeReport> pushed = push_gear_stroke(part, std::move(next), source, s);
  if (!pushed) return pushed.error();
  c.identification = std::move(*m);
  c.pushed = std::move(*pushed);
  return c;
}

}  // namespace gaugeloop

// The shaft record of one serial: lobe verdicts and index errors (derivation in shaft.h).
#include "report/shaft.h"

#include <cmath>
#include <cstdio>

#include "core/number_text.h"

namespace gaugeloop {
namespace {

double wrap_deg_360(double degrees) {
  double d = std::fmod(degrees, 360.0);
  if (d < 0.0) d += 360.0;
  return d >= 360.0 ? 0.0 : d;
}

std::string or_dash(const std::optional<double>& v) { return v ? format_signed_fixed(*v, 3) : "-"; }

nlohmann::json optional_json(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(); }

}  // namespace

double wrap_deg_180(double degrees) {
  double d = std::fmod(degrees, 360.0);  // (-360, 360)
  if (d > 180.0) d -= 360.0;
  if (d <= -180.0) d += 360.0;
  return d;
}

std::optional<NoseAngle> nose_angle(const StoredRun& run) {
  if (!run.geometry || !run.summary.phase_error_deg) return std::nullopt;
  return NoseAngle{
      wrap_deg_360(run.geometry->c_offset_deg),
      wrap_deg_360(run.geometry->c_offset_deg + run.geometry->rotation_sense * *run.summary.phase_error_deg)};
}

ShaftRecord shaft_record(const ShaftLayout& layout, const std::string& serial,
                         const std::vector<std::optional<StoredRun>>& runs) {
  ShaftRecord out;
  out.serial = serial;
  out.layout = layout;
  for (std::size_t i = 0; i < layout.lobes.size(); ++i) {
    const ShaftLobe& lobe = layout.lobes[i];
    const std::optional<StoredRun>& run = i < runs.size() ? runs[i] : std::nullopt;
    ShaftLobeRecord r;
    r.lobe = lobe;
    r.nominal_c_deg = wrap_deg_360(layout.reference_c_deg + lobe.angle_deg);
    r.index_verdict = std::string(verdict_name(Verdict::kNotJudged));
    if (!run) {
      r.verdict = "not_measured";
      r.note = "no run of this part, lobe and serial";
      out.lobes.push_back(std::move(r));
      continue;
    }
    r.run = run->summary;
    r.verdict = std::string(verdict_name(run->summary.verdict));
    r.phase_deg = run->summary.phase_error_deg;
    if (!run->geometry) {
      r.note = "the run did not record its frame mapping (c_offset_deg, rotation_sense)";
    } else if (!r.phase_deg) {
      r.note = "the run did not record its phase error";
    } else {
      const double nose_c = nose_angle(*run)->measured_c_deg;
      r.nose_c_deg = wrap_deg_360(nose_c);
      r.index_error_deg = wrap_deg_180(nose_c - (layout.reference_c_deg + lobe.angle_deg));
      if (layout.index_tolerance_deg) {
        r.index_verdict = std::string(
            verdict_name(std::abs(*r.index_error_deg) <= *layout.index_tolerance_deg ? Verdict::kIn : Verdict::kOut));
      }
    }
    out.lobes.push_back(std::move(r));
  }
  // Relative to the datum: the first lobe of the file, when its index is known.
  if (!out.lobes.empty() && out.lobes.front().index_error_deg) {
    const double datum = *out.lobes.front().index_error_deg;
    for (ShaftLobeRecord& r : out.lobes) {
      if (r.index_error_deg) r.relative_error_deg = wrap_deg_180(*r.index_error_deg - datum);
    }
  }
  bool any_out = false, all_in = !out.lobes.empty(), any_missing = false;
  for (const ShaftLobeRecord& r : out.lobes) {
    if (r.verdict == "out" || r.index_verdict == "out") any_out = true;
    if (r.verdict == "not_measured") any_missing = true;
    if (r.verdict != "in" || r.index_verdict != "in") all_in = false;
  }
  out.verdict = any_out ? "out" : all_in ? "in" : any_missing ? "incomplete" : "not_judged";
  return out;
}

Result<ShaftRecord> load_shaft_record(const RunStore& store, const ShaftLayout& layout, const std::string& serial) {
  if (serial.empty()) {
    return make_error(ErrorCode::kInvalidInput, "a shaft record needs the serial number of the shaft; give one");
  }
  if (Status s = check_run_identity("serial", serial); !s) return s.error();
  std::vector<std::optional<StoredRun>> runs;
  for (const ShaftLobe& lobe : layout.lobes) {
    RunQuery q;
    q.limit = 1;
    q.serial = serial;
    q.part = lobe.part;
    q.lobe = lobe.lobe;
    Result<std::vector<RunSummary>> newest = store.list_runs(q);
    if (!newest) return newest.error();
    if (newest->empty()) {
      runs.emplace_back();
      continue;
    }
    Result<StoredRun> run = store.load_run(newest->front().id);
    if (!run) return run.error();
    runs.emplace_back(std::move(*run));
  }
  return shaft_record(layout, serial, runs);
}

std::string shaft_record_text(const ShaftRecord& record) {
  const ShaftLayout& s = record.layout;
  std::string out = "shaft \"" + s.name + "\", serial " + record.serial +
                    ": reference at C = " + format_fixed(s.reference_c_deg, 3) + " deg, index tolerance " +
                    (s.index_tolerance_deg ? "+-" + format_fixed(*s.index_tolerance_deg, 3) + " deg" : "none") +
                    (s.lobes.empty() ? "" : ", datum lobe " + std::to_string(s.lobes.front().lobe)) + "\n";
  char line[512];
  std::snprintf(line, sizeof line, "%4s  %-20s  %6s  %-20s  %-12s  %9s  %9s  %9s  %s\n", "lobe", "part", "run",
                "started (UTC)", "verdict", "phase deg", "index deg", "to datum", "index");
  out += line;
  for (const ShaftLobeRecord& r : record.lobes) {
    std::snprintf(line, sizeof line, "%4d  %-20s  %6s  %-20s  %-12s  %9s  %9s  %9s  %s\n", r.lobe.lobe,
                  r.lobe.part.c_str(), r.run ? std::to_string(r.run->id).c_str() : "-",
                  r.run ? r.run->started_utc.c_str() : "-", r.verdict.c_str(), or_dash(r.phase_deg).c_str(),
                  or_dash(r.index_error_deg).c_str(), or_dash(r.relative_error_deg).c_str(), r.index_verdict.c_str());
    out += line;
  }
  out += "shaft verdict: " + record.verdict + "\n";
  for (const ShaftLobeRecord& r : record.lobes) {
    if (!r.note.empty()) out += "lobe " + std::to_string(r.lobe.lobe) + ": " + r.note + "\n";
  }
  return out;
}

nlohmann::json shaft_record_json(const ShaftRecord& record) {
  nlohmann::json lobes = nlohmann::json::array();
  for (const ShaftLobeRecord& r : record.lobes) {
    lobes.push_back({{"lobe", r.lobe.lobe},
                     {"part", r.lobe.part},
                     {"angle_deg", r.lobe.angle_deg},
                     {"run_id", r.run ? nlohmann::json(r.run->id) : nlohmann::json()},
                     {"started_utc", r.run ? nlohmann::json(r.run->started_utc) : nlohmann::json()},
                     {"verdict", r.verdict},
                     {"phase_deg", optional_json(r.phase_deg)},
                     {"nominal_c_deg", r.nominal_c_deg},
                     {"nose_c_deg", optional_json(r.nose_c_deg)},
                     {"index_error_deg", optional_json(r.index_error_deg)},
                     {"relative_error_deg", optional_json(r.relative_error_deg)},
                     {"index_verdict", r.index_verdict},
                     {"note", r.note}});
  }
  return {{"serial", record.serial},
          {"shaft", record.layout.name},
          {"reference_c_deg", record.layout.reference_c_deg},
          {"index_tolerance_deg", optional_json(record.layout.index_tolerance_deg)},
          {"datum_lobe", record.layout.lobes.empty() ? nlohmann::json() : nlohmann::json(record.layout.lobes[0].lobe)},
          {"lobes", std::move(lobes)},
          {"verdict", record.verdict}};
}

}  // namespace gaugeloop

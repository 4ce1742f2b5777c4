// What a record must satisfy before a single row of it is written.
#include "storage/record_checks.h"

#include <climits>
#include <cmath>
#include <cstddef>
#include <set>
#include <utility>

#include "core/utc_time.h"
#include "core/utf8.h"
#include "core/uuid.h"

namespace gaugeloop::storage_internal {
namespace {

Status check_table(const DegreeTable& table, std::string_view column, std::string_view frame) {
  for (std::size_t deg = 0; deg < table.size(); ++deg) {
    if (!std::isfinite(table[deg])) {
      return run_refused(std::string(column) + " at " + std::string(frame) + " degree " + std::to_string(deg) + " is " +
                         describe_non_finite(table[deg]) +
                         "; the computation that produced it failed, nothing was written");
    }
  }
  return {};
}

Status check_figure(double value, std::string_view column) {
  if (std::isfinite(value)) return {};
  return run_refused(std::string(column) + " is " + describe_non_finite(value) +
                     "; the computation that produced it failed, nothing was written");
}

Status check_identity(const RunRecord& run) {
  if (!is_utc_timestamp(run.started_utc)) {
    return run_refused("started_utc '" + run.started_utc + "' is not an ISO 8601 UTC time like 2026-11-22T02:34:44Z");
  }
  if (!is_utc_timestamp(run.finished_utc)) {
    return run_refused("finished_utc '" + run.finished_utc + "' is not an ISO 8601 UTC time like 2026-11-22T02:34:44Z");
  }
  if (run.finished_utc < run.started_utc) {
    return run_refused("finished_utc " + run.finished_utc + " is before started_utc " + run.started_utc);
  }
  if (run.machine.empty()) return run_refused("the machine name is empty");
  if (!run.uuid.empty() && !is_uuid(run.uuid)) {
    return run_refused("uuid '" + run.uuid + "' is not a UUID like 123e4567-e89b-42d3-a456-426614174000");
  }
  if (run.part.empty()) return run_refused("the part name is empty");
  if (run.lobe < 1) return run_refused("lobe " + std::to_string(run.lobe) + " is not 1 or more");
  if (Status s = check_run_identity("serial", run.serial); !s.ok()) return run_refused(s.error().message);
  if (Status s = check_run_identity("operator", run.operator_name); !s.ok()) return run_refused(s.error().message);
  return {};
}

Status check_measured(const MeasuredRun& m) {
  if (m.revolutions.size() < 3) {
    return run_refused("a run needs at least 3 complete revolutions, this one has " +
                       std::to_string(m.revolutions.size()));
  }
  if (m.revolutions.size() > static_cast<std::size_t>(INT_MAX / kDegreesPerRevolution)) {
    return run_refused(std::to_string(m.revolutions.size()) + " revolutions are too many");
  }
  if (m.polls < 0 || m.reconnects < 0 || m.discarded_revolutions < 0) {
    return run_refused("a negative count of polls, reconnects or discarded revolutions");
  }
  for (std::size_t i = 0; i < m.revolutions.size(); ++i) {
    const RevolutionSamples& rev = m.revolutions[i];
    // Acquisition keeps complete revolutions in the order the amplifier counted them; a
    // repeat or a step back means samples were mixed up.
    if (i > 0 && rev.revolution <= m.revolutions[i - 1].revolution) {
      return run_refused("revolution " + std::to_string(i) + " has amplifier revolution count " +
                         std::to_string(rev.revolution) + ", not after the previous one (" +
                         std::to_string(m.revolutions[i - 1].revolution) +
                         "); the revolutions are out of order or repeated");
    }
    Status ok = check_table(rev.lift_mm, "run_samples.lift_mm of revolution " + std::to_string(i), "machine");
    if (!ok.ok()) return ok;
  }
  return {};
}

Status check_analysis(const LobeAnalysis& a, const DegreeTable& correction_um) {
  const std::pair<const DegreeTable*, std::string_view> tables[] = {
      {&a.design_lift_mm, "run_profile.design_lift_mm"}, {&a.mean_lift_mm, "run_profile.mean_lift_mm"},
      {&a.spread_um, "run_profile.spread_um"},           {&a.error_um, "run_profile.error_um"},
      {&correction_um, "run_profile.correction_um"},     {&a.residual_error_um, "run_tables.residual_error_um"},
  };
  for (const auto& [table, column] : tables) {
    Status ok = check_table(*table, column, "cam");
    if (!ok.ok()) return ok;
  }
  const std::pair<double, std::string_view> figures[] = {
      {a.zero_offset_mm, "runs.zero_offset_mm"},     {a.max_abs_error_um, "runs.max_abs_error_um"},
      {a.rms_error_um, "runs.rms_error_um"},         {a.peak_to_valley_um, "runs.peak_to_valley_um"},
      {a.repeatability_um, "runs.repeatability_um"}, {a.max_abs_residual_um, "runs.max_abs_residual_um"},
      {a.rms_residual_um, "runs.rms_residual_um"},   {a.peak_to_valley_residual_um, "runs.peak_to_valley_residual_um"},
      {a.dial_runout_um, "runs.dial_runout_um"},     {a.roundness_um, "runs.roundness_um"},
  };
  for (const auto& [value, column] : figures) {
    Status ok = check_figure(value, column);
    if (!ok.ok()) return ok;
  }
  for (std::size_t h = 0; h < a.harmonic_amplitude_um.size(); ++h) {
    Status ok = check_figure(a.harmonic_amplitude_um[h], "runs.harmonic_amplitude_um harmonic " + std::to_string(h));
    if (!ok.ok()) return ok;
  }
  return {};
}

Status check_ground_with(const RunRecord& run) {
  if (run.ground_with_version && *run.ground_with_version < 1) {
    return run_refused("ground_with_version " + std::to_string(*run.ground_with_version) + " is not 1 or more");
  }
  if (!run.ground_with_source.empty() && run.ground_with_source != "plc" && run.ground_with_source != "option" &&
      run.ground_with_source != "assumed" && run.ground_with_source != "main_program") {
    return run_refused("ground_with_source '" + run.ground_with_source +
                       "' is not plc, option, assumed or main_program");
  }
  if (run.ground_with_version && run.ground_with_source.empty()) {
    return run_refused("ground_with_version is set but not who said so (ground_with_source)");
  }
  return {};
}

Status check_geometry(const Part& g) {
  if (g.rotation_sense != 1 && g.rotation_sense != -1) {
    return run_refused("the rotation sense is " + std::to_string(g.rotation_sense) + ", not +1 or -1");
  }
  const std::pair<double, std::string_view> geometry[] = {
      {g.follower_radius_mm, "parts.follower_radius_mm"}, {g.base_circle_radius_mm, "parts.base_circle_radius_mm"},
      {g.wheel_radius_mm, "parts.wheel_radius_mm"},       {g.c_offset_deg, "runs.c_offset_deg"},
      {g.probe_offset_deg, "runs.probe_offset_deg"},
  };
  for (const auto& [value, column] : geometry) {
    Status ok = check_figure(value, column);
    if (!ok.ok()) return ok;
  }
  return {};
}

}  // namespace

Error run_refused(const std::string& why) { return make_error(ErrorCode::kInvalidInput, "run not stored: " + why); }

std::string describe_non_finite(double value) {
  if (std::isnan(value)) return "NaN";
  return value > 0 ? "+infinity" : "-infinity";
}

// The non-finite checks matter beyond tidiness: SQLite binds a NaN double as NULL, and a
// per-degree BLOB holds integers only.
Status check_characteristics(const std::vector<Characteristic>& characteristics) {
  std::set<std::string_view> keys;
  for (const Characteristic& c : characteristics) {
    if (c.key.empty() || c.key.size() > 64) {
      return run_refused("a characteristic's key '" + c.key + "' is empty or longer than 64 characters");
    }
    if (!keys.insert(c.key).second) return run_refused("characteristic " + c.key + " is given twice");
    const std::string column = "run_characteristics." + c.key;
    for (double v : {c.value, c.min, c.max}) {
      if (Status ok = check_figure(v, column); !ok.ok()) return ok;
    }
    for (const std::optional<double>& limit : {c.limits.lower, c.limits.upper}) {
      if (!limit) continue;
      if (Status ok = check_figure(*limit, column + " limit"); !ok.ok()) return ok;
    }
  }
  return {};
}

Status check_run_record(const RunRecord& run) {
  if (Status s = check_identity(run); !s.ok()) return s;
  if (Status s = check_measured(run.measured); !s.ok()) return s;
  if (Status s = check_analysis(run.analysis, run.correction_um); !s.ok()) return s;
  if (Status s = check_ground_with(run); !s.ok()) return s;
  if (Status s = check_characteristics(run.characteristics); !s.ok()) return s;
  if (run.harmonics_fed_back && (*run.harmonics_fed_back < 0 || *run.harmonics_fed_back > 180)) {
    return make_error(ErrorCode::kInvalidInput, "run record: harmonics_fed_back " +
                                                    std::to_string(*run.harmonics_fed_back) +
                                                    " is outside 0..180 (the band fed back is 0..N)");
  }
  if (run.harmonic_threshold_um && !(std::isfinite(*run.harmonic_threshold_um) && *run.harmonic_threshold_um >= 0.0)) {
    return make_error(ErrorCode::kInvalidInput, "run record: harmonic_threshold_um must be a number >= 0, not " +
                                                    std::to_string(*run.harmonic_threshold_um));
  }
  if (run.geometry) return check_geometry(*run.geometry);
  return {};
}

Status check_table_figures(const std::string& what, const TableFacts& table) {
  const std::optional<int>& block_count = table.block_count;
  const std::optional<int>& point_count = table.point_count;
  const std::optional<double>& command_error_um = table.command_error_um;
  const std::optional<double>& correction_max_um = table.correction_max_um;
  if (block_count && *block_count < 0) {
    return make_error(ErrorCode::kInvalidInput,
                      what + ": block_count " + std::to_string(*block_count) + " is negative");
  }
  if (point_count && *point_count < 0) {
    return make_error(ErrorCode::kInvalidInput,
                      what + ": point_count " + std::to_string(*point_count) + " is negative");
  }
  if (command_error_um && !(std::isfinite(*command_error_um) && *command_error_um >= 0.0)) {
    return make_error(ErrorCode::kInvalidInput,
                      what + ": command_error_um is " +
                          (std::isfinite(*command_error_um) ? std::to_string(*command_error_um) + ", below 0"
                                                            : describe_non_finite(*command_error_um)));
  }
  if (correction_max_um && !std::isfinite(*correction_max_um)) {
    return make_error(ErrorCode::kInvalidInput, what + ": correction_max_um is not finite");
  }
  return {};
}

Status check_push(std::int64_t run_id, const NcPush& push) {
  if (push.nc_file.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot record an NC file for run " + std::to_string(run_id) + ": the NC file path is empty");
  }
  const std::string what = "cannot record NC file " + push.nc_file + " for run " + std::to_string(run_id);
  if (!push.pushed_utc.empty() && !is_utc_timestamp(push.pushed_utc)) {
    return bad_bound(what + ": pushed_utc", push.pushed_utc);
  }
  if (push.table_version < 0) {
    return make_error(ErrorCode::kInvalidInput, what + ": table version " + std::to_string(push.table_version) +
                                                    " is negative (0: the next one)");
  }
  return check_table_figures(what, push.table);
}

Error bad_bound(std::string_view what, const std::string& value) {
  return make_error(ErrorCode::kInvalidInput,
                    std::string(what) + " '" + value + "' is not an ISO 8601 UTC time like 2026-11-22T02:34:44Z");
}

bool is_time_bound(std::string_view s) { return s.empty() || is_utc_timestamp(s); }

}  // namespace gaugeloop::storage_internal

namespace gaugeloop {

Status check_run_identity(std::string_view what, std::string_view value) {
  constexpr std::size_t kMaxCharacters = 64;
  std::size_t characters = 0;
  for (std::size_t i = 0; i < value.size();) {
    char32_t cp = 0;
    const std::size_t length = utf8_sequence_at(value, i, cp);
    if (length == 0) {
      return make_error(ErrorCode::kInvalidInput, std::string(what) + " is not valid UTF-8 at byte " +
                                                      std::to_string(i + 1) + "; write it as plain text");
    }
    if (cp < 0x20 || (cp >= 0x7F && cp <= 0x9F)) {
      return make_error(ErrorCode::kInvalidInput, std::string(what) + " has a control character at character " +
                                                      std::to_string(characters + 1) +
                                                      " (tab, new line...); write it on one line of plain text");
    }
    ++characters;
    i += length;
  }
  if (characters > kMaxCharacters) {
    return make_error(ErrorCode::kInvalidInput, std::string(what) + " is " + std::to_string(characters) +
                                                    " characters long; at most " + std::to_string(kMaxCharacters) +
                                                    " are kept, shorten it");
  }
  return {};
}

}  // namespace gaugeloop

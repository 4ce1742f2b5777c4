// The Prometheus text of the run database's series and of the build.
#include "service/metrics_text.h"

#include <spdlog/spdlog.h>

#include <ctime>
#include <nlohmann/json.hpp>
#include <optional>

#include "core/utc_time.h"

namespace gaugeloop {
namespace {

// Micrometres in a metre: Prometheus asks for base units. Dividing (not multiplying by 1e-6,
// which is not exact in binary) gives the double nearest the metres: 4 um prints as 4e-06.
constexpr double kUmPerMetre = 1e6;

std::string number(double v) {
  nlohmann::json j = v;
  return j.dump();  // shortest text that reads back exactly
}

void family(std::string& out, const char* name, const char* type, const char* help) {
  out += "# HELP ";
  out += name;
  out += ' ';
  out += help;
  out += "\n# TYPE ";
  out += name;
  out += ' ';
  out += type;
  out += '\n';
}

}  // namespace

std::string prometheus_label_value(const std::string& v) {
  std::string out;
  for (const char c : v) {
    if (c == '\\' || c == '"') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

void append_store_metrics(const StoreMetrics& m, std::string& out) {
  family(out, "gaugeloop_runs_stored", "gauge", "Runs in the database, by status.");
  for (const auto& [status, n] : m.runs_by_status) {
    out += "gaugeloop_runs_stored{status=\"" + prometheus_label_value(status) + "\"} " + std::to_string(n) + "\n";
  }
  family(out, "gaugeloop_events_stored", "gauge",
         "Faults, refusals and service steps (info) in the database, by kind.");
  for (const auto& [kind, n] : m.events_by_kind) {
    out += "gaugeloop_events_stored{kind=\"" + prometheus_label_value(kind) + "\"} " + std::to_string(n) + "\n";
  }
  family(out, "gaugeloop_runs_by_verdict", "gauge",
         "Runs in the database by verdict against their lobe's tolerances (in, out, not_judged).");
  for (const auto& [verdict, n] : m.runs_by_verdict) {
    out += "gaugeloop_runs_by_verdict{verdict=\"" + prometheus_label_value(verdict) + "\"} " + std::to_string(n) + "\n";
  }
  family(out, "gaugeloop_pending_tables", "gauge", "NC tables waiting for approval.");
  out += "gaugeloop_pending_tables " + std::to_string(m.pending_tables) + "\n";

  const auto labels = [](const LobeLastRun& r) {
    return "{machine=\"" + prometheus_label_value(r.machine) + "\",part=\"" + prometheus_label_value(r.part) +
           "\",lobe=\"" + std::to_string(r.lobe) + "\"}";
  };
  family(out, "gaugeloop_last_run_max_abs_error_meters", "gauge",
         "Largest lift error of the newest run of each lobe (metres, cam frame).");
  for (const LobeLastRun& r : m.last_runs) {
    out +=
        "gaugeloop_last_run_max_abs_error_meters" + labels(r) + " " + number(r.max_abs_error_um / kUmPerMetre) + "\n";
  }
  family(out, "gaugeloop_last_run_out_of_tolerance", "gauge",
         "1 when the newest run of each lobe is out of tolerance, 0 when in; absent when not judged.");
  for (const LobeLastRun& r : m.last_runs) {
    if (r.verdict == Verdict::kNotJudged) continue;
    out += "gaugeloop_last_run_out_of_tolerance" + labels(r) + (r.verdict == Verdict::kOut ? " 1\n" : " 0\n");
  }
  family(out, "gaugeloop_last_run_id", "gauge", "Id of the newest run of each lobe.");
  for (const LobeLastRun& r : m.last_runs) {
    out += "gaugeloop_last_run_id" + labels(r) + " " + std::to_string(r.run_id) + "\n";
  }
  family(out, "gaugeloop_last_run_started_timestamp_seconds", "gauge", "When the newest run of each lobe started.");
  for (const LobeLastRun& r : m.last_runs) {
    if (const std::optional<std::time_t> t = epoch_of_utc(r.started_utc)) {
      out += "gaugeloop_last_run_started_timestamp_seconds" + labels(r) + " " + std::to_string(*t) + "\n";
    }
  }
}

Status append_database_metrics(const RunStore& store, std::string& out) {
  Result<StoreMetrics> m = store.metrics_snapshot();
  if (!m) return m.error();
  append_store_metrics(*m, out);
  return {};
}

void append_build_info(std::string& out) {
  family(out, "gaugeloop_build_info", "gauge", "Always 1; the labels say which gaugeloop answers.");
  out += "gaugeloop_build_info{version=\"" + prometheus_label_value(GAUGELOOP_VERSION) + "\"} 1\n";
}

void append_database_up(bool up, std::string& out) {
  family(out, "gaugeloop_database_up", "gauge", "Whether the run database could be read for this scrape.");
  out += up ? "gaugeloop_database_up 1\n" : "gaugeloop_database_up 0\n";
}

bool DatabaseStateLog::note(DatabaseState state, const std::string& error) {
  const auto before = static_cast<DatabaseState>(last_.exchange(static_cast<int>(state)));
  if (before == state) return false;
  if (state == DatabaseState::kFailed) {
    spdlog::warn("http: /metrics cannot read the run database: {} (logged again only after it was read)", error);
    return true;
  }
  if (before == DatabaseState::kFailed) {
    spdlog::info(state == DatabaseState::kUp ? "http: /metrics reads the run database again"
                                             : "http: /metrics finds no run database file any more");
    return true;
  }
  return false;
}

}  // namespace gaugeloop

// `runs export --format dfq`: selects runs, gathers their characteristics (and harmonics if
// asked) and writes the AQDEF file with report/dfq.
#include "cli/commands_dfq.h"

#include <cstdio>
#include <vector>

#include "core/atomic_file.h"
#include "report/dfq.h"
#include "report/run_json.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

// Every run of a range or shaft: far more than a plant keeps of one lobe.
constexpr int kMaxExportedRuns = 1000000;

bool has_range_selection(const DfqExportRequest& r) {
  return !r.part.empty() || r.lobe != 0 || !r.machine.empty() || !r.serial.empty() || !r.since.empty() ||
         !r.until.empty();
}

Result<RunCharacteristics> one_run(const RunStore& store, std::int64_t id, const DataPaths& paths) {
  Result<StoredRun> run = store.load_run(id);
  if (!run) {
    if (run.error().code == ErrorCode::kNotFound) {
      return make_error(ErrorCode::kNotFound,
                        run.error().message + "; `gaugeloop runs list " + paths.where() + "` shows the ids");
    }
    return run.error();
  }
  return RunCharacteristics{run->summary, run->characteristics};
}

Result<std::vector<RunCharacteristics>> selected(const RunStore& store, const DfqExportRequest& r, std::int64_t id,
                                                 const DataPaths& paths) {
  if (id != 0) {
    Result<RunCharacteristics> one = one_run(store, id, paths);
    if (!one) return one.error();
    return std::vector<RunCharacteristics>{*one};
  }
  RunQuery q;
  q.limit = kMaxExportedRuns;
  q.part = r.part;
  q.lobe = r.lobe;
  q.machine = r.machine;
  q.serial = r.serial;
  if (Status t = set_time_bounds(r.since, r.until, q.since_utc, q.until_utc); !t) return t.error();
  Result<std::vector<RunCharacteristics>> runs = store.characteristics(q);
  if (!runs) return runs.error();
  if (runs->empty()) {
    return make_error(ErrorCode::kNotFound,
                      "no run matches the selection; `gaugeloop runs list` with the same --part, --lobe, "
                      "--machine, --serial, --since and --until shows what is stored");
  }
  return runs;
}

}  // namespace

std::shared_ptr<DfqExportRequest> add_dfq_export_options(CLI::App& export_cmd) {
  auto r = std::make_shared<DfqExportRequest>();
  export_cmd.add_option("--format", r->format, "csv: one run per cam degree; dfq: AQDEF (Q-DAS) characteristics")
      ->capture_default_str()
      ->check(CLI::IsMember({"csv", "dfq"}));
  export_cmd.add_option("--run", r->run, "dfq: this run (as the positional id)")->check(CLI::PositiveNumber);
  export_cmd.add_option("--part", r->part, "dfq: runs of this part");
  export_cmd.add_option("--lobe", r->lobe, "dfq: runs of this lobe")->check(CLI::Range(1, 1000));
  export_cmd.add_option("--machine", r->machine, "dfq: runs on this machine");
  export_cmd.add_option("--serial", r->serial, "dfq: every lobe of the shaft with this serial number");
  export_cmd.add_option("--since", r->since, "dfq: runs from this UTC date or time on, e.g. 2026-11-22");
  export_cmd.add_option("--until", r->until, "dfq: runs up to this UTC date or time, inclusive");
  export_cmd.add_option("--harmonics", r->harmonics, "dfq: add the lift error's harmonics 1..N as characteristics")
      ->check(CLI::Range(1, kMaxDfqHarmonics));
  export_cmd.add_option("--operation", r->operation, "dfq: the operation (K1086); empty: not written")
      ->capture_default_str();
  return r;
}

int refuse_dfq_options_for_csv(const DfqExportRequest& r) {
  if (r.run != 0 || has_range_selection(r) || r.harmonics != 0) {
    return report_error(make_error(ErrorCode::kInvalidInput,
                                   "--run, --part, --lobe, --machine, --serial, --since, --until and --harmonics "
                                   "choose runs for --format dfq; the CSV export takes one run id"));
  }
  return kExitOk;
}

int cmd_export_dfq(const DfqExportRequest& r, const DataPaths& paths, std::int64_t positional_id,
                   const std::string& out) {
  if (positional_id != 0 && r.run != 0 && positional_id != r.run) {
    return report_error(make_error(
        ErrorCode::kInvalidInput,
        "two run ids given (" + std::to_string(positional_id) + " and --run " + std::to_string(r.run) + "); give one"));
  }
  const std::int64_t id = positional_id != 0 ? positional_id : r.run;
  if (id != 0 && has_range_selection(r)) {
    return report_error(make_error(ErrorCode::kInvalidInput,
                                   "a run id and --part/--lobe/--machine/--serial/--since/--until both given; give "
                                   "the run or the selection"));
  }
  if (id == 0 && !has_range_selection(r)) {
    return report_error(make_error(ErrorCode::kInvalidInput,
                                   "which runs? give a run id, --part P --lobe L (with --since/--until for a time "
                                   "range) or --serial S for a shaft"));
  }
  if (!r.serial.empty()) {
    if (Status s = check_run_identity("--serial", r.serial); !s) return report_error(s.error());
  }
  Result<RunStore> store = open_history_read_only(paths);
  if (!store) return report_error(store.error());
  Result<std::vector<RunCharacteristics>> runs = selected(*store, r, id, paths);
  if (!runs) return report_error(runs.error());
  if (r.harmonics > 0) {
    // The amplitudes live in each run's analysis, which the characteristics query does not read.
    for (RunCharacteristics& rc : *runs) {
      Result<StoredRun> full = store->load_run(rc.run.id);
      if (!full) return report_error(full.error());
      const std::vector<Characteristic> h = harmonic_characteristics(full->analysis, r.harmonics);
      rc.characteristics.insert(rc.characteristics.end(), h.begin(), h.end());
    }
  }
  DfqOptions options;
  options.harmonics = r.harmonics;
  options.operation = r.operation;
  Result<std::string> dfq = write_dfq(*runs, options);
  if (!dfq) return report_error(dfq.error());
  if (out.empty()) {
    std::fwrite(dfq->data(), 1, dfq->size(), stdout);
    return kExitOk;
  }
  if (Status w = write_file_atomically(out, *dfq); !w) return report_file_error(w.error());
  std::printf("%zu run%s exported to %s\n", runs->size(), runs->size() == 1 ? "" : "s", out.c_str());
  return kExitOk;
}

}  // namespace gaugeloop

// Copying one grinder's run database into the plant's central history (docs/plant.md,
// "The central history"): runs (summary, settings and characteristics; the per-degree tables
// and raw revolutions when asked), NC pushes (the program text when asked) and events, each
// keyed by its UUID; and the grinder's prunes of raw samples, followed.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

struct CentralSyncOptions {
  int batch_size = 200;  // records per PostgreSQL transaction; >= 1
  int max_batches = 0;   // stop after this many batches (0: until every record is copied)
  // Read the file from its first record again, ignoring where the last sync stopped: after the
  // file was replaced or restored from a backup. Records already there are found by UUID.
  bool from_start = false;
  // Copy each push's program text too (nc_pushes.program_text; NULL otherwise): the office can
  // read what was sent to the control. A push copied before without its text gets it.
  bool programs = false;
  // Copy each run's per-degree tables (run_tables: design, mean, spread, error, correction,
  // residual) and, unless pruned, its raw revolutions (run_raw): an office reads a run's lift
  // and error curves without the grinder's file. A run copied before without them gets them.
  bool per_degree = false;
  // Called before each batch's commit with the table ("runs", "nc_pushes", "events") and the
  // batch's number (1, 2... over the whole sync); an error aborts that batch's transaction and
  // ends the sync with it. For tests: a sync that fails half way.
  std::function<Status(std::string_view table, int batch)> before_commit;
};

// The service's own sync, [plant.central] (docs/plant.md, "The service syncs itself").
struct CentralSyncSettings {
  std::string url;  // postgresql://...; checked by parse_central_url, no password in it
  // A sync at least this often; also right after each run the service stores, while the last
  // sync succeeded.
  std::chrono::seconds interval{60};
  int batch_size = 200;     // as CentralSyncOptions
  bool programs = false;    // as CentralSyncOptions
  bool per_degree = false;  // as CentralSyncOptions
  // Not in the config file: the first wait after a failed sync, doubling up to `interval`.
  std::chrono::milliseconds retry_min{5000};
};

struct CentralSyncTableCounts {
  std::int64_t inserted = 0;       // copied by this sync
  std::int64_t already_there = 0;  // found by UUID (an earlier sync, or another grinder's copy)
  std::int64_t last_local_id = 0;  // where the sync of this table stands now
  // --from-start only: the id a sync from the start stopped at before and this one went on
  // from (0: it began at the first record).
  std::int64_t resumed_after = 0;
};

struct CentralSyncCounts {
  std::string source;  // the file synced, as the central history names it (its absolute path)
  CentralSyncTableCounts runs, pushes, events;
  // Runs copied before their raw samples were pruned on the grinder, marked pruned here by this
  // sync (their raw revolutions deleted here too).
  std::int64_t pruned = 0;
  int batches = 0;         // transactions committed
  bool caught_up = false;  // false: stopped by max_batches with records left to copy
};

// Copies the records of `local` (in id order, after where the last sync of `machine` from this
// file stopped) into the central history at `url`, creating or upgrading its schema first.
// Each batch is one PostgreSQL transaction that inserts its records (ON CONFLICT (uuid) DO
// NOTHING) and advances sync_progress together: a sync that stops anywhere resumes where the
// last committed batch ended and never copies a record twice. Runs first, then pushes (which
// mark their run pushed), then the prunes followed, then events.
// `machine` names the grinder (not empty, at most 64 characters, no control characters).
// Errors: kInvalidInput for a bad URL, machine or option; kStorage for a server that cannot be
// reached or fails (the batches committed before stay), a newer central schema; kRefused when
// the file is not the one the last sync read (a record at the id where it stopped is gone or
// has another UUID): from_start reads it whole.
Result<CentralSyncCounts> sync_to_central(const RunStore& local, const std::string& url, const std::string& machine,
                                          const CentralSyncOptions& options = {});

}  // namespace gaugeloop

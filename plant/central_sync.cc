// Copying a grinder's file into the central history, batch by batch, each batch and the
// progress it makes in one PostgreSQL transaction.
#include "plant/central_sync.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <filesystem>
#include <future>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "core/utc_time.h"
#include "plant/central_history.h"
#include "plant/central_internal.h"
#include "plant/central_schema.h"

namespace gaugeloop {

using central_internal::CentralConnection;
using central_internal::Params;

namespace {

// The runs go by COPY into a temporary table of the runs table's columns but synced_utc (made
// once per connection, emptied at each commit), and from there into runs with ON CONFLICT DO
// NOTHING, which returns the runs that were new; their characteristics go by COPY straight into
// run_characteristic_sets, one row a run: a run that was new has none there yet. COPY is what
// PostgreSQL reads fastest (no statement to parse per row, rows inserted in groups).
constexpr std::string_view kRunColumns =
    "uuid, source_machine, source, local_id, started_utc, finished_utc, machine, part, lobe, gauge, note, status, "
    "revolutions, degrees_captured, polls, reconnects, discarded_revolutions, zero_offset_mm, max_abs_error_um, "
    "rms_error_um, peak_to_valley_um, repeatability_um, nc_file, phase_error_deg, base_circle_runout_um, "
    "harmonic_amplitude_um, correction_in_force_run, settings_hash, settings, raw_pruned_utc, ground_with_version, "
    "ground_with_source, inspection, serial, operator, verdict, lift_error_reference, max_abs_residual_um, "
    "rms_residual_um, peak_to_valley_residual_um, dial_runout_um, roundness_um";
constexpr std::size_t kRunWidth = 42;  // and synced_utc, given at the insert
constexpr std::string_view kIncomingRuns = "sync_incoming_runs";

// A run's characteristics as one row of arrays (central schema 5).
constexpr std::string_view kCharacteristicSetColumns =
    "run_uuid, key_list, unit_list, value_list, min_value_list, max_value_list, lower_limit_list, upper_limit_list, "
    "verdict_list, from_deg_list, to_deg_list";
constexpr std::size_t kCharacteristicSetWidth = 11;

// A run's per-degree tables and raw revolutions (central schema 7), with CentralSyncOptions::
// per_degree: by COPY into temporary tables of their columns, then into theirs with ON CONFLICT
// DO NOTHING, so that a sync from the start with them fills in runs copied before without them.
// The raw revolutions only of a run the central history does not know as pruned.
constexpr std::string_view kTableColumns =
    "run_uuid, design_lift_mm, mean_lift_mm, spread_um, error_um, correction_um, residual_error_um";
constexpr std::size_t kTableWidth = 7;
constexpr std::string_view kIncomingTables = "sync_incoming_tables";
constexpr std::string_view kRawColumns = "run_uuid, amplifier_revolutions, lift_mm";
constexpr std::size_t kRawWidth = 3;
constexpr std::string_view kIncomingRaw = "sync_incoming_raw";

constexpr std::string_view kInsertPushHead = R"sql(
INSERT INTO nc_pushes (uuid, run_uuid, machine, source_machine, source, local_id, local_run_id, pushed_utc, nc_file,
                       table_version, reason, interpolation, block_count, command_error_um, point_count,
                       correction_max_um, program_hash, synced_utc, program_text)
VALUES )sql";
constexpr std::size_t kPushWidth = 19;
// A push there without its program text gets it (a sync with programs after one without); the
// pushes that were new say so (xmax 0: inserted, not updated).
constexpr std::string_view kInsertPushTail =
    " ON CONFLICT (uuid) DO UPDATE SET program_text = EXCLUDED.program_text"
    " WHERE nc_pushes.program_text IS NULL AND EXCLUDED.program_text IS NOT NULL"
    " RETURNING run_uuid, xmax = 0";

// As RunStore::record_push does to the local row: the run is pushed, and its nc_file is the
// program last pushed from it.
constexpr std::string_view kMarkPushed = R"sql(
UPDATE runs SET status = 'pushed',
                nc_file = (SELECT p.nc_file FROM nc_pushes AS p WHERE p.run_uuid = $1 ORDER BY p.local_id DESC LIMIT 1)
WHERE uuid = $1)sql";

constexpr std::string_view kInsertEventHead = R"sql(
INSERT INTO events (uuid, source_machine, source, local_id, at_utc, kind, code, machine, part, lobe, local_run_id,
                    message, synced_utc, run_uuid)
VALUES )sql";
constexpr std::size_t kEventWidth = 14;
constexpr std::string_view kInsertEventTail = " ON CONFLICT (uuid) DO NOTHING RETURNING 1";

// Inserts `rows` (each `width` parameters) in as few statements as PostgreSQL's limit on
// parameters allows; the rows the statements returned, those `inserted` says were new when given.
std::int64_t insert_rows(pqxx::work& tx, std::string_view head, std::string_view tail, std::size_t width,
                         const std::vector<Params>& rows,
                         const std::function<bool(const pqxx::row&)>& inserted = nullptr) {
  const std::size_t per_statement = std::max<std::size_t>(1, central_internal::kMaxParameters / width);
  std::int64_t count = 0;
  for (std::size_t from = 0; from < rows.size(); from += per_statement) {
    const std::size_t n = std::min(per_statement, rows.size() - from);
    Params all;
    for (std::size_t i = from; i < from + n; ++i) all.append(rows[i]);
    const pqxx::result r = central_internal::exec(
        tx, std::string(head) + central_internal::values_list(n, width) + std::string(tail), all);
    for (const auto& row : r) {
      if (!inserted || inserted(row)) ++count;
    }
  }
  return count;
}

// A COPY into `table` of the columns `columns` (a comma-separated list).
pqxx::stream_to open_copy(pqxx::work& tx, std::string_view table, std::string_view columns) {
  // libpqxx joins the names with commas: one element that is the whole list is the list.
  return pqxx::stream_to(tx, std::string(table), std::vector<std::string>{std::string(columns)});
}

// One row of kWidth values; a NULL value is COPY's NULL.
template <std::size_t kWidth>
void copy_row(pqxx::stream_to& copy, const Params& row) {
  const std::vector<const char*> values = row.pointers();
  std::array<const char*, kWidth> fields{};
  std::copy_n(values.begin(), kWidth, fields.begin());
  copy << fields;
}

// `value` as an element of a PostgreSQL array literal: NULL, a number as it is, a text quoted.
void append_array_element(std::string& list, const char* value, bool text) {
  if (value == nullptr) {
    list += "NULL";
    return;
  }
  if (!text) {
    list += value;
    return;
  }
  list += '"';
  for (const char* c = value; *c != '\0'; ++c) {
    if (*c == '"' || *c == '\\') list += '\\';
    list += *c;
  }
  list += '"';
}

// `table` as a float8 array literal, {v0,v1,...,v359}: each value the shortest text that reads
// back as the same double, as the parameters are.
void append_degree_array(std::string& out, const DegreeTable& table) {
  char buf[40];
  out += '{';
  for (std::size_t d = 0; d < table.size(); ++d) {
    if (d > 0) out += ',';
    const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, table[d]);
    out.append(buf, r.ptr);
  }
  out += '}';
}

std::string degree_array(const DegreeTable& table) {
  std::string out;
  append_degree_array(out, table);
  return out;
}

std::string harmonics_json(const LobeAnalysis& a) {
  std::string out = "[";
  for (std::size_t h = 0; h < a.harmonic_amplitude_um.size(); ++h) {
    Params p;  // the same exact number text the parameters use
    p.number(a.harmonic_amplitude_um[h]);
    out += (h == 0 ? "" : ",") + std::string(p.pointers()[0]);
  }
  return out + "]";
}

// A run as the sync sends it: its runs row (all but synced_utc) and its characteristics' row,
// made from the file while the batch before is being sent.
struct OutgoingRun {
  std::int64_t id = 0;
  std::string uuid;
  Params row;
  Params characteristics;  // the run_characteristic_sets row; none for a run without any
  Params tables;           // the run_tables row, when the sync copies them
  Params raw;              // the run_raw row, when the sync copies them and they were not pruned
};

// The run's per-degree tables and, unless pruned, its raw revolutions (revolution by row).
void add_per_degree(OutgoingRun& out, const StoredRun& run) {
  const LobeAnalysis& a = run.analysis;
  out.tables.text(out.uuid).text(degree_array(a.design_lift_mm)).text(degree_array(a.mean_lift_mm));
  out.tables.text(degree_array(a.spread_um)).text(degree_array(a.error_um)).text(degree_array(run.correction_um));
  out.tables.text(degree_array(a.residual_error_um));
  if (run.revolutions.empty()) return;
  std::string counts = "{";
  std::string lift = "{";
  for (std::size_t i = 0; i < run.revolutions.size(); ++i) {
    if (i > 0) {
      counts += ',';
      lift += ',';
    }
    counts += std::to_string(run.revolutions[i].revolution);
    append_degree_array(lift, run.revolutions[i].lift_mm);
  }
  out.raw.text(out.uuid).text(counts + "}").text(lift + "}");
}

OutgoingRun outgoing_run(const StoredRun& run, const std::string& machine, const std::string& source) {
  const RunSummary& s = run.summary;
  const LobeAnalysis& a = run.analysis;
  OutgoingRun out{s.id, s.uuid, {}, {}, {}, {}};
  Params& p = out.row;
  p.text(s.uuid).text(machine).text(source).integer(s.id).text(s.started_utc).text(run.finished_utc);
  p.text(s.machine).text(s.part).integer(std::int64_t{s.lobe}).text(run.gauge).text(s.note).text(s.status);
  p.integer(std::int64_t{s.revolutions}).integer(std::int64_t{s.degrees_captured}).integer(run.polls);
  p.integer(run.reconnects).integer(run.discarded_revolutions).number(a.zero_offset_mm).number(s.max_abs_error_um);
  p.number(s.rms_error_um).number(s.peak_to_valley_um).number(s.repeatability_um).text_or_null(s.nc_file);
  p.number(s.phase_error_deg).number(s.base_circle_runout_um).text(harmonics_json(a));
  p.integer(run.correction_in_force_run).text_or_null(s.settings_hash).text_or_null(run.settings);
  p.text_or_null(s.raw_pruned_utc);
  p.integer(run.ground_with_version ? std::optional<std::int64_t>(*run.ground_with_version) : std::nullopt);
  p.text_or_null(run.ground_with_source).text(run.inspection ? "true" : "false");
  p.text_or_null(s.serial).text_or_null(s.operator_name).text(verdict_name(s.verdict));
  p.text(run.lift_error_reference == LiftErrorReference::kNominal ? "nominal" : "best_fit");
  p.number(a.max_abs_residual_um).number(a.rms_residual_um).number(a.peak_to_valley_residual_um);
  p.number(a.dial_runout_um).number(a.roundness_um);
  if (!run.characteristics.empty()) {
    // Array literals of the exact texts the parameters use; every text element quoted.
    std::array<std::string, kCharacteristicSetWidth - 1> lists;
    for (std::string& l : lists) l = "{";
    for (std::size_t i = 0; i < run.characteristics.size(); ++i) {
      const Characteristic& c = run.characteristics[i];
      Params e;
      e.text(c.key).text(c.unit).number(c.value).number(c.min).number(c.max).number(c.limits.lower);
      e.number(c.limits.upper).text(verdict_name(c.verdict));
      e.integer(c.from_deg ? std::optional<std::int64_t>(*c.from_deg) : std::nullopt);
      e.integer(c.to_deg ? std::optional<std::int64_t>(*c.to_deg) : std::nullopt);
      const std::vector<const char*> values = e.pointers();
      for (std::size_t k = 0; k < lists.size(); ++k) {
        if (i > 0) lists[k] += ',';
        const bool text = k == 0 || k == 1 || k == 7;
        append_array_element(lists[k], values[k], text);
      }
    }
    out.characteristics.text(s.uuid);
    for (std::string& l : lists) out.characteristics.text(l + "}");
  }
  return out;
}

// The batch's per-degree tables and raw revolutions, if the sync copies them; a run's that are
// there already stay as they are.
void insert_per_degree(pqxx::work& tx, const std::vector<OutgoingRun>& runs) {
  const bool any = std::any_of(runs.begin(), runs.end(), [](const OutgoingRun& r) { return r.tables.size() > 0; });
  if (!any) return;
  {
    pqxx::stream_to copy = open_copy(tx, kIncomingTables, kTableColumns);
    for (const OutgoingRun& r : runs) {
      if (r.tables.size() > 0) copy_row<kTableWidth>(copy, r.tables);
    }
    copy.complete();
  }
  {
    pqxx::stream_to copy = open_copy(tx, kIncomingRaw, kRawColumns);
    for (const OutgoingRun& r : runs) {
      if (r.raw.size() > 0) copy_row<kRawWidth>(copy, r.raw);
    }
    copy.complete();
  }
  tx.exec("INSERT INTO run_tables (" + std::string(kTableColumns) + ") SELECT " + std::string(kTableColumns) +
          " FROM " + std::string(kIncomingTables) + " ON CONFLICT (run_uuid) DO NOTHING");
  tx.exec("INSERT INTO run_raw (" + std::string(kRawColumns) +
          ") SELECT i.run_uuid, i.amplifier_revolutions, i.lift_mm"
          " FROM " +
          std::string(kIncomingRaw) +
          " AS i JOIN runs AS r ON r.uuid = i.run_uuid"
          " WHERE r.raw_pruned_utc IS NULL ON CONFLICT (run_uuid) DO NOTHING");
}

// The runs, and the characteristics of those that were new (a run already there keeps its own:
// DO NOTHING); the runs that were new.
std::int64_t insert_runs(pqxx::work& tx, const std::vector<OutgoingRun>& runs, const std::string& now) {
  {
    pqxx::stream_to copy = open_copy(tx, kIncomingRuns, kRunColumns);
    for (const OutgoingRun& r : runs) copy_row<kRunWidth>(copy, r.row);
    copy.complete();
  }
  Params synced;
  synced.text(now);
  const pqxx::result inserted = central_internal::exec(
      tx,
      "INSERT INTO runs (" + std::string(kRunColumns) + ", synced_utc) SELECT " + std::string(kRunColumns) +
          ", $1 FROM " + std::string(kIncomingRuns) + " ON CONFLICT (uuid) DO NOTHING RETURNING uuid",
      synced);
  std::set<std::string> fresh;
  for (const auto& row : inserted) fresh.insert(central_internal::text_of(row[0]));
  pqxx::stream_to copy = open_copy(tx, "run_characteristic_sets", kCharacteristicSetColumns);
  for (const OutgoingRun& r : runs) {
    if (fresh.count(r.uuid) == 0 || r.characteristics.size() == 0) continue;
    copy_row<kCharacteristicSetWidth>(copy, r.characteristics);
  }
  copy.complete();
  insert_per_degree(tx, runs);
  return static_cast<std::int64_t>(inserted.size());
}

// The pushes, and each run a new push came from marked pushed; the pushes that were new.
std::int64_t insert_pushes(pqxx::work& tx, const std::vector<ReplicatedPush>& pushes, const std::string& machine,
                           const std::string& source, const std::string& now) {
  auto optional_int = [](std::optional<int> v) {
    return v ? std::optional<std::int64_t>(*v) : std::optional<std::int64_t>();
  };
  std::vector<Params> rows;
  for (const ReplicatedPush& r : pushes) {
    const NcPush& push = r.push;
    Params p;
    p.text(push.uuid).text(r.run_uuid).text(r.machine).text(machine).text(source).integer(push.id);
    p.integer(push.run_id).text(push.pushed_utc).text(push.nc_file).integer(std::int64_t{push.table_version});
    p.text_or_null(push.reason).text_or_null(push.table.interpolation).integer(optional_int(push.table.block_count));
    p.number(push.table.command_error_um).integer(optional_int(push.table.point_count));
    p.number(push.table.correction_max_um).text_or_null(push.program_hash).text(now);
    p.text_or_null(push.program_text.value_or(""));
    rows.push_back(std::move(p));
  }
  std::vector<std::string> runs;  // of the pushes that were new
  const std::int64_t inserted =
      insert_rows(tx, kInsertPushHead, kInsertPushTail, kPushWidth, rows, [&runs](const pqxx::row& row) {
        if (!row[1].as<bool>()) return false;  // there before, given its program text
        runs.push_back(central_internal::text_of(row[0]));
        return true;
      });
  std::sort(runs.begin(), runs.end());
  runs.erase(std::unique(runs.begin(), runs.end()), runs.end());
  for (const std::string& run_uuid : runs) {
    Params mark;
    mark.text(run_uuid);
    central_internal::exec(tx, std::string(kMarkPushed), mark);
  }
  return inserted;
}

std::int64_t insert_events(pqxx::work& tx, const std::vector<StoredEvent>& events, const std::string& machine,
                           const std::string& source, const std::string& now) {
  std::vector<Params> rows;
  for (const StoredEvent& e : events) {
    const EventRecord& ev = e.event;
    Params p;
    p.text(ev.uuid).text(machine).text(source).integer(e.id).text(ev.at_utc).text(event_kind_name(ev.kind));
    p.text(ev.code).text(ev.machine).text(ev.part).integer(std::int64_t{ev.lobe}).integer(ev.run_id).text(ev.message);
    p.text(now).text_or_null(e.run_uuid);
    rows.push_back(std::move(p));
  }
  return insert_rows(tx, kInsertEventHead, kInsertEventTail, kEventWidth, rows);
}

// One table's records as the sync reads them from the file.
template <typename Record>
struct TableReader {
  std::string_view table;  // sync_progress.table_name
  std::string_view noun;   // "run", "push", "event": for messages
  // The records after `after_id` in id order, at most `limit`.
  std::function<Result<std::vector<Record>>(std::int64_t after_id, int limit)> read;
  std::function<std::int64_t(const Record&)> id;
  std::function<std::string(const Record&)> uuid;
  // Inserts a batch's records; the number that were new (the rest were there by UUID).
  std::function<std::int64_t(pqxx::work&, const std::vector<Record>&, const std::string& machine,
                             const std::string& source, const std::string& now)>
      insert;
};

class Syncer {
 public:
  Syncer(CentralConnection& c, std::string machine, std::string source, const CentralSyncOptions& options,
         CentralSyncCounts& counts)
      : c_(c), machine_(std::move(machine)), source_(std::move(source)), options_(options), counts_(counts) {}

  // Copies one table; false when max_batches stopped it.
  //
  // A plain sync goes on after last_local_id and moves it. A sync from the start goes on after
  // rescan_local_id (where a sync from the start stopped before; none: the first record) and
  // moves that; it moves last_local_id only forward, and to where it ends when it reaches the
  // file's last record (the file may have been replaced by a shorter one), so stopping it
  // part-way never sends the plain sync back over what it had copied.
  template <typename Record>
  Result<bool> sync(const TableReader<Record>& reader, CentralSyncTableCounts& counts) {
    const bool rescan = options_.from_start;
    std::optional<std::int64_t> position;  // rescan: where this sync stands
    std::string position_uuid;             // the UUID of the record at `position`
    bool anchor_checked = false;
    // Waited for on every way out, by its future's destructor.
    std::optional<std::pair<std::int64_t, std::future<Result<std::vector<Record>>>>> ahead;
    for (;;) {
      if (options_.max_batches > 0 && counts_.batches >= options_.max_batches) return false;
      const std::string operation = "copy " + std::string(reader.table) + " of " + source_;
      try {
        pqxx::work tx(*c_.conn);
        const Params key = progress_row(tx, reader.table);
        // Locked until the commit: a second sync of the same file waits here and then goes on
        // from where this batch ends.
        pqxx::result progress = central_internal::exec(
            tx,
            "SELECT last_local_id, last_uuid, rescan_local_id, rescan_uuid FROM sync_progress WHERE machine = $1 "
            "AND source = $2 AND table_name = $3 FOR UPDATE",
            key);
        const std::int64_t stored = progress[0][0].as<std::int64_t>();
        const std::string stored_uuid = central_internal::text_of(progress[0][1]);
        if (!anchor_checked) {
          anchor_checked = true;
          if (!rescan) {
            if (Status s = check_anchor(reader, stored, stored_uuid); !s.ok()) return s.error();
          } else if (!progress[0][2].is_null()) {
            // A sync from the start stopped before: on from there, if its record is still the same.
            const std::int64_t was = progress[0][2].as<std::int64_t>();
            const std::string was_uuid = central_internal::text_of(progress[0][3]);
            if (check_anchor(reader, was, was_uuid).ok()) {
              position = was;
              position_uuid = was_uuid;
              counts.resumed_after = was;
            }
          }
          if (rescan && !position) position = 0;
        }
        const std::int64_t after = position.value_or(stored);
        // The batch read while the last one was sent, if it starts where this one does (another
        // sync of the same file may have moved the progress meanwhile).
        Result<std::vector<Record>> records =
            ahead && ahead->first == after ? ahead->second.get() : reader.read(after, options_.batch_size);
        ahead.reset();
        if (!records.ok()) return records.error();
        if (records->empty()) {
          counts.last_local_id = after;
          if (!rescan) return true;  // nothing left: the transaction rolls back, nothing was written
          // The whole file seen: the plain sync goes on from its last record, this file's.
          Params done;
          done.integer(after).text_or_null(position_uuid).text(utc_now()).append(key);
          central_internal::exec(tx,
                                 "UPDATE sync_progress SET last_local_id = $1, last_uuid = $2, updated_utc = $3, "
                                 "rescan_local_id = NULL, rescan_uuid = NULL "
                                 "WHERE machine = $4 AND source = $5 AND table_name = $6",
                                 done);
          tx.commit();
          return true;
        }
        if (options_.max_batches == 0 || counts_.batches + 1 < options_.max_batches) {
          // The next batch is read from the file (a thread of its own) while the server takes this
          // one: the file's reading and the server's writing overlap.
          const std::int64_t next = reader.id(records->back());
          ahead.emplace(next, std::async(std::launch::async, [&reader, next, limit = options_.batch_size] {
                          return reader.read(next, limit);
                        }));
        }
        const std::string now = utc_now();
        const std::int64_t inserted = reader.insert(tx, *records, machine_, source_, now);
        const Record& last = records->back();
        Params moved;
        moved.integer(reader.id(last)).text(reader.uuid(last)).text(now).append(key);
        central_internal::exec(tx,
                               rescan ? "UPDATE sync_progress SET rescan_local_id = $1, rescan_uuid = $2, "
                                        "updated_utc = $3, "
                                        "last_uuid = CASE WHEN $1 >= last_local_id THEN $2 ELSE last_uuid END, "
                                        "last_local_id = GREATEST(last_local_id, $1) "
                                        "WHERE machine = $4 AND source = $5 AND table_name = $6"
                                      : "UPDATE sync_progress SET last_local_id = $1, last_uuid = $2, updated_utc = $3 "
                                        "WHERE machine = $4 AND source = $5 AND table_name = $6",
                               moved);
        if (options_.before_commit) {
          if (Status s = options_.before_commit(reader.table, counts_.batches + 1); !s.ok()) {
            return committed_before(s.error());
          }
        }
        tx.commit();
        ++counts_.batches;
        counts.inserted += inserted;
        counts.already_there += static_cast<std::int64_t>(records->size()) - inserted;
        counts.last_local_id = reader.id(last);
        if (position) {
          position = reader.id(last);
          position_uuid = reader.uuid(last);
        }
      } catch (const std::exception& e) {
        return committed_before(central_internal::database_error(c_.url, operation, e));
      }
    }
  }

  // Follows the grinder's prunes: each run whose raw samples were pruned (runs prune) after it
  // was copied is marked so here too (raw_pruned_utc) and its raw revolutions are deleted here,
  // in order of the prunes, from where the last sync of this file stopped following them
  // (sync_progress.pruned_through_utc and pruned_through_id of its runs' row). A run copied
  // after its prune came marked. False when max_batches stopped it.
  Result<bool> follow_prunes(const RunStore& local) {
    // A prune's runs are a UUID and a time each: many more to a transaction than runs.
    const int limit = options_.batch_size * 25;
    // A sync from the start follows them from the first prune (the file may be another one).
    std::optional<std::pair<std::string, std::int64_t>> through;
    if (options_.from_start) through.emplace("", 0);
    // A grinder that never pruned a run (the usual case): nothing to follow, and no transaction
    // on the central server to find that out.
    Result<std::vector<PrunedRun>> any = local.runs_pruned_after("", 0, 1);
    if (!any.ok()) return any.error();
    if (any->empty()) return true;
    for (;;) {
      if (options_.max_batches > 0 && counts_.batches >= options_.max_batches) return false;
      try {
        pqxx::work tx(*c_.conn);
        const Params key = progress_row(tx, "runs");
        const pqxx::result progress =
            central_internal::exec(tx,
                                   "SELECT coalesce(pruned_through_utc, ''), coalesce(pruned_through_id, 0) "
                                   "FROM sync_progress WHERE machine = $1 AND source = $2 AND table_name = $3 "
                                   "FOR UPDATE",
                                   key);
        if (!through) through.emplace(central_internal::text_of(progress[0][0]), progress[0][1].as<std::int64_t>());
        Result<std::vector<PrunedRun>> pruned = local.runs_pruned_after(through->first, through->second, limit);
        if (!pruned.ok()) return pruned.error();
        if (pruned->empty()) return true;  // nothing new: the transaction rolls back
        std::string uuids = "{";
        std::string times = "{";
        for (std::size_t i = 0; i < pruned->size(); ++i) {
          if (i > 0) {
            uuids += ',';
            times += ',';
          }
          append_array_element(uuids, (*pruned)[i].uuid.c_str(), true);
          append_array_element(times, (*pruned)[i].pruned_utc.c_str(), true);
        }
        Params lists;
        lists.text(uuids + "}").text(times + "}");
        const pqxx::result marked = central_internal::exec(
            tx,
            "UPDATE runs AS r SET raw_pruned_utc = p.pruned_utc FROM unnest($1::text[], $2::text[]) AS p (uuid, "
            "pruned_utc) WHERE r.uuid = p.uuid AND r.raw_pruned_utc IS NULL RETURNING 1",
            lists);
        Params just_uuids;
        just_uuids.text(uuids + "}");
        central_internal::exec(tx, "DELETE FROM run_raw WHERE run_uuid = ANY ($1::text[])", just_uuids);
        Params moved;
        moved.text(pruned->back().pruned_utc).integer(pruned->back().id).text(utc_now()).append(key);
        central_internal::exec(tx,
                               "UPDATE sync_progress SET pruned_through_utc = $1, pruned_through_id = $2, "
                               "updated_utc = $3 WHERE machine = $4 AND source = $5 AND table_name = $6 "
                               // Forward only: a sync from the start that stops part-way leaves it.
                               "AND (coalesce(pruned_through_utc, ''), coalesce(pruned_through_id, 0)) < ($1, $2)",
                               moved);
        tx.commit();
        ++counts_.batches;
        counts_.pruned += static_cast<std::int64_t>(marked.size());
        through.emplace(pruned->back().pruned_utc, pruned->back().id);
        if (static_cast<int>(pruned->size()) < limit) return true;
      } catch (const std::exception& e) {
        return committed_before(central_internal::database_error(c_.url, "follow the prunes of " + source_, e));
      }
    }
  }

 private:
  // The key of this file's sync_progress row for `table` (machine, source, table), the row
  // made if it is not there yet.
  Params progress_row(pqxx::work& tx, std::string_view table) {
    Params key;
    key.text(machine_).text(source_).text(table);
    Params row = key;
    row.text(utc_now());
    central_internal::exec(tx,
                           "INSERT INTO sync_progress (machine, source, table_name, updated_utc) "
                           "VALUES ($1, $2, $3, $4) ON CONFLICT DO NOTHING",
                           row);
    return key;
  }

  // The record where the last sync stopped must still be there with its UUID; otherwise the
  // ids after it name other records than those the central history has, and some would never
  // be copied.
  template <typename Record>
  Status check_anchor(const TableReader<Record>& reader, std::int64_t stored, const std::string& stored_uuid) {
    if (stored == 0 || stored_uuid.empty()) return {};
    Result<std::vector<Record>> at = reader.read(stored - 1, 1);
    if (!at.ok()) return at.error();
    std::string found;
    if (at->empty() || reader.id(at->front()) != stored) {
      found = "holds no " + std::string(reader.noun) + " " + std::to_string(stored);
    } else if (reader.uuid(at->front()) != stored_uuid) {
      found = "holds another " + std::string(reader.noun) + " under id " + std::to_string(stored);
    } else {
      return {};
    }
    return make_error(ErrorCode::kRefused,
                      "run database " + source_ + " is not the file the central history last synced for machine " +
                          machine_ + ": it " + found + " (" + std::string(reader.noun) + " " + stored_uuid +
                          " was synced there), so it was replaced or restored from a backup; sync it again with "
                          "--from-start, which compares every record by UUID and copies none twice");
  }

  Error committed_before(Error e) const {
    if (counts_.batches > 0) {
      e.message += counts_.batches == 1 ? std::string("; the batch before it is")
                                        : "; the " + std::to_string(counts_.batches) + " batches before it are";
      e.message += " in the central history: sync again to copy the rest";
    } else {
      e.message += "; nothing was copied";
    }
    return e;
  }

  CentralConnection& c_;
  std::string machine_;
  std::string source_;
  const CentralSyncOptions& options_;
  CentralSyncCounts& counts_;
};

std::string source_of(const RunStore& local) {
  std::error_code ec;
  std::filesystem::path p = std::filesystem::weakly_canonical(local.path(), ec);
  if (ec) p = std::filesystem::absolute(local.path(), ec).lexically_normal();
  return p.string();
}

}  // namespace

Result<CentralSyncCounts> sync_to_central(const RunStore& local, const std::string& url, const std::string& machine,
                                          const CentralSyncOptions& options) {
  if (machine.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot sync to the central history without the grinder's name; give it with --machine");
  }
  if (Status s = check_run_identity("the machine name", machine); !s.ok()) return s.error();
  if (options.batch_size < 1) {
    return make_error(ErrorCode::kInvalidInput, "cannot sync to the central history: the batch size " +
                                                    std::to_string(options.batch_size) + " is not 1 or more");
  }
  if (options.max_batches < 0) {
    return make_error(ErrorCode::kInvalidInput, "cannot sync to the central history: the batch limit " +
                                                    std::to_string(options.max_batches) + " is negative");
  }
  Result<CentralUrl> parsed = parse_central_url(url);
  if (!parsed.ok()) return parsed.error();
  Result<CentralConnection> c = central_internal::connect(*parsed);
  if (!c.ok()) return c.error();
  if (Status s = central_internal::migrate(*c); !s.ok()) return s.error();

  CentralSyncCounts counts;
  counts.source = source_of(local);
  Syncer syncer(*c, machine, counts.source, options, counts);

  const TableReader<OutgoingRun> runs{
      "runs",
      "run",
      [&](std::int64_t after, int limit) -> Result<std::vector<OutgoingRun>> {
        Result<std::vector<StoredRun>> read = local.run_records_after(after, limit, options.per_degree);
        if (!read.ok()) return read.error();
        std::vector<OutgoingRun> out;
        out.reserve(read->size());
        for (const StoredRun& run : *read) {
          out.push_back(outgoing_run(run, machine, counts.source));
          if (options.per_degree) add_per_degree(out.back(), run);
        }
        return out;
      },
      [](const OutgoingRun& r) { return r.id; },
      [](const OutgoingRun& r) { return r.uuid; },
      [incoming_made = false, &options](pqxx::work& tx, const std::vector<OutgoingRun>& batch, const std::string&,
                                        const std::string&, const std::string& now) mutable {
        // Made by the first batch with runs, not by a sync that finds nothing new (the usual
        // one, every interval): a sync whose batch fails ends with its connection.
        if (!incoming_made) {
          tx.exec("CREATE TEMPORARY TABLE " + std::string(kIncomingRuns) + " ON COMMIT DELETE ROWS AS SELECT " +
                  std::string(kRunColumns) + " FROM runs WITH NO DATA");
          if (options.per_degree) {
            tx.exec("CREATE TEMPORARY TABLE " + std::string(kIncomingTables) + " ON COMMIT DELETE ROWS AS SELECT " +
                    std::string(kTableColumns) + " FROM run_tables WITH NO DATA");
            tx.exec("CREATE TEMPORARY TABLE " + std::string(kIncomingRaw) + " ON COMMIT DELETE ROWS AS SELECT " +
                    std::string(kRawColumns) + " FROM run_raw WITH NO DATA");
          }
          incoming_made = true;
        }
        return insert_runs(tx, batch, now);
      },
  };
  const TableReader<ReplicatedPush> pushes{
      "nc_pushes",
      "push",
      [&local, &options](std::int64_t after, int limit) { return local.pushes_after(after, limit, options.programs); },
      [](const ReplicatedPush& p) { return p.push.id; },
      [](const ReplicatedPush& p) { return p.push.uuid; },
      insert_pushes,
  };
  const TableReader<StoredEvent> events{
      "events",
      "event",
      [&local](std::int64_t after, int limit) { return local.events_after(after, limit); },
      [](const StoredEvent& e) { return e.id; },
      [](const StoredEvent& e) { return e.event.uuid; },
      insert_events,
  };

  Result<bool> done = syncer.sync(runs, counts.runs);
  if (done.ok() && *done) done = syncer.follow_prunes(local);
  if (done.ok() && *done) done = syncer.sync(pushes, counts.pushes);
  if (done.ok() && *done) done = syncer.sync(events, counts.events);
  if (!done.ok()) return done.error();
  counts.caught_up = *done;
  return counts;
}

}  // namespace gaugeloop

// Version 2's conversion of the runs version 1 stored (JSON revolutions and profile rows) to
// per-degree BLOBs, and the views that show those BLOBs as rows. Part of a released migration:
// the SQL it writes and what it converts never change.
#include "storage/migration_v2.h"

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "storage/degree_blob.h"
#include "storage/degree_json.h"
#include "storage/sqlite_db.h"

namespace gaugeloop::storage_internal {
namespace {

// The signed int32 whose 8 hex digits (hex() of 4 big-endian bytes) are in `h`. Each digit:
// '0'-'9' are 0x30-0x39 and 'A'-'F' are 0x41-0x46, so (code & 15) + 9 * (code >> 6) is its
// value; a first digit above '7' makes the number negative.
std::string int32_from_hex_sql(const std::string& h) {
  std::string sql;
  for (int i = 1; i <= 8; ++i) {
    const std::string c = "unicode(substr(" + h + ", " + std::to_string(i) + ", 1))";
    if (i > 1) sql += " + ";
    sql += "(((" + c + " & 15) + 9 * (" + c + " >> 6)) << " + std::to_string(4 * (8 - i)) + ")";
  }
  return "(" + sql + " - 4294967296 * (unicode(substr(" + h + ", 1, 1)) > 55))";
}

constexpr std::string_view kConvertV1 = "migrate the schema to version 2 (convert the stored runs)";

Error v1_run_damaged(const Connection& conn, std::int64_t run_id, const std::string& what) {
  return make_error(ErrorCode::kStorage,
                    "run database " + conn.path.string() + ": cannot " + std::string(kConvertV1) + ": run " +
                        std::to_string(run_id) + " is damaged: " + what +
                        "; restore a backup, or delete that run with sqlite3 and open the database again");
}

// run_revolutions (one JSON row per revolution) into run_raw (one row per run).
Status convert_v1_revolutions(Connection& conn) {
  const std::string operation(kConvertV1);
  auto damaged = [&](std::int64_t run_id, const std::string& what) { return v1_run_damaged(conn, run_id, what); };
  Result<Statement> ins_raw = Statement::prepare(
      conn, "INSERT INTO run_raw (run_id, amplifier_revolutions, lift) VALUES (?1, ?2, ?3)", operation);
  if (!ins_raw.ok()) return ins_raw.error();
  Result<Statement> revs = Statement::prepare(conn,
                                              "SELECT run_id, revolution_index, amplifier_revolution, lift_mm"
                                              " FROM run_revolutions ORDER BY run_id, revolution_index",
                                              operation);
  if (!revs.ok()) return revs.error();
  std::int64_t current = -1;
  std::string amplifier;
  std::string lift;
  int count = 0;
  auto flush_raw = [&]() -> Status {
    if (current < 0) return {};
    ins_raw->reset();
    ins_raw->bind(1, current);
    ins_raw->bind(2, std::string_view(amplifier + "]"));
    ins_raw->bind(3, Blob{lift});
    return ins_raw->run();
  };
  for (;;) {
    Result<bool> row = revs->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    const std::int64_t run_id = revs->column<std::int64_t>(0);
    if (run_id != current) {
      if (Status s = flush_raw(); !s.ok()) return s;
      current = run_id;
      amplifier = "[";
      lift.clear();
      count = 0;
    }
    if (revs->column<int>(1) != count) return damaged(run_id, "revolution " + std::to_string(count) + " is missing");
    Result<DegreeTable> table = degree_table_from_json(revs->column<std::string>(3));
    if (!table.ok())
      return damaged(run_id, "lift_mm of revolution " + std::to_string(count) + ": " + table.error().message);
    Status s = append_degree_blob(*table, kCountsPerMm, "lift_mm of revolution " + std::to_string(count), lift);
    if (!s.ok()) return damaged(run_id, s.error().message);
    if (count > 0) amplifier += ",";
    amplifier += std::to_string(revs->column<std::int64_t>(2));
    ++count;
  }
  return flush_raw();
}

// run_profile (one row per cam degree) into run_tables (one row per run).
Status convert_v1_profiles(Connection& conn) {
  const std::string operation(kConvertV1);
  auto damaged = [&](std::int64_t run_id, const std::string& what) { return v1_run_damaged(conn, run_id, what); };
  Result<Statement> ins_tables = Statement::prepare(conn,
                                                    "INSERT INTO run_tables (run_id, design_lift, mean_lift, spread,"
                                                    " error, correction) VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
                                                    operation);
  if (!ins_tables.ok()) return ins_tables.error();
  Result<Statement> prof = Statement::prepare(conn,
                                              "SELECT run_id, angle_deg, design_lift_mm, mean_lift_mm, spread_um,"
                                              " error_um, correction_um FROM run_profile ORDER BY run_id, angle_deg",
                                              operation);
  if (!prof.ok()) return prof.error();
  std::array<DegreeTable, 5> tables{};
  std::int64_t current = -1;
  int deg = 0;
  auto flush_tables = [&]() -> Status {
    if (current < 0) return {};
    if (deg != kDegreesPerRevolution) {
      return damaged(current, "its profile has " + std::to_string(deg) + " rows instead of 360");
    }
    static constexpr std::array<double, 5> kScale = {kCountsPerMm, kCountsPerMm, kCountsPerUm, kCountsPerUm,
                                                     kCountsPerUm};
    static constexpr std::array<std::string_view, 5> kName = {"design_lift_mm", "mean_lift_mm", "spread_um", "error_um",
                                                              "correction_um"};
    ins_tables->reset();
    ins_tables->bind(1, current);
    for (std::size_t i = 0; i < tables.size(); ++i) {
      std::string blob;
      Status s = append_degree_blob(tables[i], kScale[i], kName[i], blob);
      if (!s.ok()) return damaged(current, s.error().message);
      ins_tables->bind(static_cast<int>(i) + 2, Blob{blob});
    }
    return ins_tables->run();
  };
  for (;;) {
    Result<bool> row = prof->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    const std::int64_t run_id = prof->column<std::int64_t>(0);
    if (run_id != current) {
      if (Status s = flush_tables(); !s.ok()) return s;
      current = run_id;
      deg = 0;
    }
    if (deg >= kDegreesPerRevolution || prof->column<int>(1) != deg) {
      return damaged(run_id, "the profile row for cam degree " + std::to_string(deg) + " is missing");
    }
    for (std::size_t i = 0; i < tables.size(); ++i) {
      tables[i][static_cast<std::size_t>(deg)] = prof->column<double>(static_cast<int>(i) + 2);
    }
    ++deg;
  }
  return flush_tables();
}

}  // namespace

// Like int32_from_hex_sql, part of the released migration 2: never changed.
std::string schema_v2_after() {
  const std::string counts = "1e-7";  // mm per count
  const std::string um = "1e-4";      // um per count
  auto at = [](const std::string& blob, const std::string& offset) {
    return "hex(substr(" + blob + ", " + offset + " + 1, 4))";
  };
  std::string sql = R"sql(
DROP VIEW run_samples;
DROP TABLE run_revolutions;
DROP TABLE run_profile;

-- Raw samples one per row, for plain SQL: angle_deg here is the machine degree of C.
CREATE VIEW run_samples (run_id, revolution_index, angle_deg, lift_mm, amplifier_revolution) AS
  SELECT run_id, revolution_index, angle_deg, )sql";
  sql += int32_from_hex_sql("h") + " * " + counts + ", amplifier_revolution\n";
  sql += "  FROM (SELECT r.run_id, CAST(v.key AS INTEGER) AS revolution_index, d.angle_deg,\n";
  sql +=
      "               v.value AS amplifier_revolution, " + at("r.lift", "1440 * v.key + 4 * d.angle_deg") + " AS h\n";
  sql += "        FROM run_raw AS r, json_each(r.amplifier_revolutions) AS v, degrees AS d);\n";
  sql += R"sql(
-- The analysed lobe and the correction, one row per cam degree (0 at the nose).
CREATE VIEW run_profile (run_id, angle_deg, design_lift_mm, mean_lift_mm, spread_um, error_um,
                         correction_um) AS
  SELECT run_id, angle_deg, )sql";
  sql += int32_from_hex_sql("hd") + " * " + counts + ",\n    ";
  sql += int32_from_hex_sql("hm") + " * " + counts + ",\n    ";
  sql += int32_from_hex_sql("hs") + " * " + um + ",\n    ";
  sql += int32_from_hex_sql("he") + " * " + um + ",\n    ";
  sql += int32_from_hex_sql("hc") + " * " + um + "\n";
  sql += "  FROM (SELECT t.run_id, d.angle_deg, " + at("t.design_lift", "4 * d.angle_deg") + " AS hd, " +
         at("t.mean_lift", "4 * d.angle_deg") + " AS hm,\n               " + at("t.spread", "4 * d.angle_deg") +
         " AS hs, " + at("t.error", "4 * d.angle_deg") + " AS he, " + at("t.correction", "4 * d.angle_deg") +
         " AS hc\n        FROM run_tables AS t, degrees AS d);\n";
  sql += R"sql(
-- The error's harmonic amplitudes, one row per harmonic 0..30.
CREATE VIEW run_harmonics (run_id, harmonic, amplitude_um) AS
  SELECT r.id, CAST(h.key AS INTEGER), h.value
  FROM runs AS r, json_each(r.harmonic_amplitude_um) AS h;
)sql";
  return sql;
}

// A run whose rows do not add up stops the migration, naming it: nothing is lost, the database
// stays at version 1.
Status convert_v1_rows(Connection& conn) {
  if (Status s = convert_v1_revolutions(conn); !s.ok()) return s;
  if (Status s = convert_v1_profiles(conn); !s.ok()) return s;
  // A run row without its tables would load as damaged later; say so now, by id.
  Result<Statement> orphan = Statement::prepare(conn,
                                                "SELECT id FROM runs WHERE id NOT IN (SELECT run_id FROM run_tables)"
                                                " OR id NOT IN (SELECT run_id FROM run_raw) ORDER BY id LIMIT 1",
                                                std::string(kConvertV1));
  if (!orphan.ok()) return orphan.error();
  Result<bool> row = orphan->step();
  if (!row.ok()) return row.error();
  if (*row) {
    return v1_run_damaged(conn, orphan->column<std::int64_t>(0), "it has no raw revolutions or no profile rows");
  }
  return {};
}

}  // namespace gaugeloop::storage_internal

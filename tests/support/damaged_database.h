// Damaging a real run database as a failing disk or a bad copy would, for tests of the checks.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace gaugeloop::testing {

// The first result column of `sql` on a plain connection to the existing file `db`, as text
// ("" if none). Read-write, though `sql` should only read: SQLite verifies CHECK constraints
// in integrity_check only on a connection that may write.
inline std::string sqlite_text(const std::filesystem::path& db, const std::string& sql) {
  sqlite3* raw = nullptr;
  std::string out;
  if (sqlite3_open_v2(db.c_str(), &raw, SQLITE_OPEN_READWRITE, nullptr) == SQLITE_OK) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(raw, sql.c_str(), -1, &st, nullptr) == SQLITE_OK && sqlite3_step(st) == SQLITE_ROW) {
      const unsigned char* text = sqlite3_column_text(st, 0);
      out = text != nullptr ? reinterpret_cast<const char*>(text) : "";
    }
    sqlite3_finalize(st);
  }
  sqlite3_close(raw);
  return out;
}

// Overwrites 16 bytes with 0xFF at the start of the cell content of the runs table's root
// page (a leaf while the table holds a few runs): the header of the cell there (its payload
// size and row id) becomes nonsense, whatever the values in the row, so integrity_check and
// quick_check report the page while the file still opens. (Bytes inside a text value would
// not do: a corrupted text is still a text.) The database must be closed (no -wal). Returns
// false if the file could not be written.
inline bool damage_runs_table(const std::filesystem::path& db) {
  const std::int64_t page_size = std::stoll(sqlite_text(db, "PRAGMA page_size"));
  const std::int64_t root = std::stoll(sqlite_text(db, "SELECT rootpage FROM sqlite_schema WHERE name = 'runs'"));
  const std::int64_t page_at = (root - 1) * page_size;
  std::fstream f(db, std::ios::in | std::ios::out | std::ios::binary);
  // Bytes 5-6 of a b-tree page header: where the cell content area starts.
  unsigned char header[8] = {};
  f.seekg(page_at);
  f.read(reinterpret_cast<char*>(header), sizeof header);
  const std::int64_t content_start = header[5] * 256 + header[6];
  f.seekp(page_at + content_start);
  f.write(std::string(16, '\xff').data(), 16);
  return static_cast<bool>(f);
}

}  // namespace gaugeloop::testing

// The SQLite layer under RunStore: how a connection opens and configures itself, binding by
// name and in order, typed columns, and the failures it reports. Real SQLite, on disk and in
// memory.
#include "storage/sqlite_db.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <string>

#include "storage_test_support.h"
#include "tests/support/text.h"

namespace gaugeloop::storage_internal {
namespace {

using testing::TempDir;

using testing::has;

// The first column of the one row `sql` returns, as text.
std::string query_text(Connection& conn, const char* sql) {
  Result<Statement> st = Statement::prepare(conn, sql, "read a setting");
  EXPECT_TRUE(st.ok()) << st.error().message;
  if (!st.ok()) return {};
  Result<std::optional<std::string>> v = st->first([](const Statement& s) { return s.column<std::string>(0); });
  EXPECT_TRUE(v.ok()) << v.error().message;
  return v.ok() ? v->value_or("") : std::string();
}

std::unique_ptr<Connection> open_memory() {
  Result<std::unique_ptr<Connection>> conn = Connection::open(":memory:", OpenMode::kWriter, ":memory:");
  EXPECT_TRUE(conn.ok()) << conn.error().message;
  if (!conn.ok()) return nullptr;
  Status made = exec(**conn, "CREATE TABLE t (id INTEGER PRIMARY KEY, name TEXT NOT NULL, size REAL, bytes BLOB)",
                     "create a table");
  EXPECT_TRUE(made.ok()) << made.error().message;
  return std::move(*conn);
}

TEST(SqliteDb, TheWriterOpensInWalModeWithForeignKeysAndCreatesTheFile) {
  TempDir dir;
  const std::filesystem::path file = dir.path() / "w.sqlite";
  Result<std::unique_ptr<Connection>> conn = Connection::open(file.string(), OpenMode::kWriter, file);
  ASSERT_TRUE(conn.ok()) << conn.error().message;
  EXPECT_TRUE(std::filesystem::exists(file));
  EXPECT_EQ(query_text(**conn, "PRAGMA journal_mode"), "wal");
  EXPECT_EQ(query_text(**conn, "PRAGMA foreign_keys"), "1");
  EXPECT_EQ((*conn)->path, file);
}

TEST(SqliteDb, TheCheckerNeverCreatesAFile) {
  TempDir dir;
  const std::filesystem::path file = dir.path() / "missing.sqlite";
  Result<std::unique_ptr<Connection>> conn = Connection::open(file.string(), OpenMode::kChecker, file);
  ASSERT_FALSE(conn.ok());
  EXPECT_EQ(conn.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(has(conn.error().message, "cannot open the file to check it")) << conn.error().message;
  EXPECT_FALSE(std::filesystem::exists(file));
}

TEST(SqliteDb, BindsByNameAndInOrderAndReadsTypedColumns) {
  std::unique_ptr<Connection> conn = open_memory();
  ASSERT_NE(conn, nullptr);
  Result<Statement> ins =
      Statement::prepare(*conn, "INSERT INTO t (name, size, bytes) VALUES (:name, :size, :bytes)", "insert a row");
  ASSERT_TRUE(ins.ok()) << ins.error().message;
  ins->bind(":name", std::string("lobe"));
  ins->bind(":size", std::optional<double>());
  ins->bind(":bytes", Blob{std::string_view("\0\1", 2)});
  ASSERT_TRUE(ins->run().ok());
  EXPECT_EQ(conn->last_insert_rowid(), 1);
  EXPECT_EQ(conn->changes(), 1);

  Result<Statement> ins2 = Statement::prepare(*conn, "INSERT INTO t (name, size) VALUES (?1, ?2)", "insert a row");
  ASSERT_TRUE(ins2.ok()) << ins2.error().message;
  ins2->bind_all(std::string_view("cam"), 2.5);
  ASSERT_TRUE(ins2->run().ok());
  EXPECT_EQ(conn->last_insert_rowid(), 2);

  Result<Statement> q = Statement::prepare(*conn, "SELECT id, name, size, bytes FROM t ORDER BY id", "read rows");
  ASSERT_TRUE(q.ok()) << q.error().message;
  struct Row {
    std::int64_t id;
    std::string name;
    std::optional<double> size;
    std::string bytes;
  };
  Result<std::vector<Row>> rows = q->collect([](const Statement& s) {
    return Row{s.column<std::int64_t>(0), s.column<std::string>(1), s.column<std::optional<double>>(2),
               s.column_blob(3)};
  });
  ASSERT_TRUE(rows.ok()) << rows.error().message;
  ASSERT_EQ(rows->size(), 2u);
  EXPECT_EQ((*rows)[0].name, "lobe");
  EXPECT_FALSE((*rows)[0].size.has_value());
  EXPECT_EQ((*rows)[0].bytes, std::string("\0\1", 2));
  EXPECT_EQ((*rows)[1].id, 2);
  EXPECT_EQ((*rows)[1].size, std::optional<double>(2.5));
  EXPECT_TRUE((*rows)[1].bytes.empty());  // NULL
}

TEST(SqliteDb, AnUnknownParameterNameIsReportedByStepNamingIt) {
  std::unique_ptr<Connection> conn = open_memory();
  ASSERT_NE(conn, nullptr);
  Result<Statement> ins = Statement::prepare(*conn, "INSERT INTO t (name) VALUES (:name)", "insert a named row");
  ASSERT_TRUE(ins.ok()) << ins.error().message;
  ins->bind(":nmae", std::string_view("typo"));
  Status s = ins->run();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(has(s.error().message, "cannot insert a named row")) << s.error().message;
  EXPECT_TRUE(has(s.error().message, ":nmae")) << s.error().message;
  EXPECT_EQ(conn->changes(), 0);
}

TEST(SqliteDb, ChangesCountsTheRowsTheLastStatementChanged) {
  std::unique_ptr<Connection> conn = open_memory();
  ASSERT_NE(conn, nullptr);
  ASSERT_TRUE(exec(*conn, "INSERT INTO t (name) VALUES ('a'), ('b'), ('c')", "insert rows").ok());
  Result<Statement> upd = Statement::prepare(*conn, "UPDATE t SET size = 1 WHERE name <> :name", "update rows");
  ASSERT_TRUE(upd.ok()) << upd.error().message;
  upd->bind(":name", std::string_view("b"));
  ASSERT_TRUE(upd->run().ok());
  EXPECT_EQ(conn->changes(), 2);
}

}  // namespace
}  // namespace gaugeloop::storage_internal

// The one set-up of a test on a run database: a fresh directory (TempDir) and a RunStore
// open for writing on a real SQLite file in it, as the product opens it.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <optional>

#include "storage/run_store.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop::testing {

// The database file of a test's directory (not there until the first open).
inline std::filesystem::path db_in(const TempDir& dir) { return dir / "data" / "runs.sqlite"; }

class StoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<RunStore> opened = RunStore::open(db_in(dir_));
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    store_.emplace(std::move(opened).value());
  }

  RunStore& store() { return *store_; }
  std::filesystem::path db() const { return db_in(dir_); }

  TempDir dir_;
  std::optional<RunStore> store_;  // closed before dir_ is removed
};

}  // namespace gaugeloop::testing

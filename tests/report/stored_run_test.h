// A fixture for the report's tests: runs inserted into a run database on disk and loaded back
// as the report reads them.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <optional>

#include "storage/run_store.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop::testing {

class StoredRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto store = RunStore::open(dir_.path() / "runs.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    store_.emplace(std::move(*store));
  }

  std::int64_t insert(const RunRecord& record) {
    auto id = store_->insert_run(record);
    EXPECT_TRUE(id.ok()) << id.error().message;
    return id.ok() ? *id : 0;
  }

  StoredRun load(std::int64_t id) {
    auto run = store_->load_run(id);
    EXPECT_TRUE(run.ok()) << run.error().message;
    return run.ok() ? *run : StoredRun{};
  }

  TempDir dir_;
  std::optional<RunStore> store_;
};

}  // namespace gaugeloop::testing

// The central history from the command line, as a user runs it: `plant sync`, and the query
// commands with --db printing exactly what they print from the grinder's file.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "core/tolerance.h"
#include "storage/run_store.h"
#include "tests/support/cli.h"
#include "tests/support/postgres_server.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

using testing::CommandResult;
using testing::run_command;
using testing::shared_postgres;

using testing::has;

class CentralCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(shared_postgres().running());
    url_ = shared_postgres().create_database();
    ASSERT_FALSE(url_.empty());
    Result<RunStore> store = RunStore::open(dir_ / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    // Lobe 1 of intake on g1 over three days and on g2, lobe 2 once; judged, one pushed.
    const char* days[] = {"2020-11-20T08:00:00Z", "2020-11-21T08:00:00Z", "2020-11-22T08:00:00Z"};
    for (int i = 0; i < 3; ++i) {
      RunRecord r = testing::sample_run("intake", 1, "g1", days[i], 12.0 - 3.3 * i);
      r.characteristics = {single_characteristic("phase", "deg", 0.01 * i, Limits{-0.05, 0.05}),
                           single_characteristic("roundness", "um", 1.0 + 0.37 * i, Limits{std::nullopt, 1.5})};
      r.verdict = combined_verdict({r.characteristics[0].verdict, r.characteristics[1].verdict});
      r.serial = "S-" + std::to_string(i);
      ASSERT_TRUE(store->insert_run(r).ok());
    }
    ASSERT_TRUE(store->insert_run(testing::sample_run("intake", 1, "g2", "2020-11-21T09:00:00Z", 7.25)).ok());
    ASSERT_TRUE(store->insert_run(testing::sample_run("intake", 2, "g1", "2020-11-21T09:00:00Z", 30.0)).ok());
    ASSERT_TRUE(store->record_nc_file(2, "nc/CAM_INTAKE_L1.SPF").ok());
    ASSERT_TRUE(store->record_event(testing::sample_refusal_event()).ok());
    data_ = " --data-dir " + dir_.path().string();
  }

  testing::TempDir dir_;
  std::string url_;
  std::string data_;
};

TEST_F(CentralCliTest, QueriesWithDbPrintExactlyWhatTheyPrintFromTheFile) {
  CommandResult sync = run_command("plant sync --to " + url_ + data_ + " --machine cell-1");
  ASSERT_EQ(sync.exit_code, 0) << sync.output;
  EXPECT_TRUE(has(sync.output, "(machine cell-1) to the central history at " + url_)) << sync.output;
  EXPECT_TRUE(has(sync.output, "runs       5 copied, 0 already there (up to id 5)")) << sync.output;
  EXPECT_TRUE(has(sync.output, "NC pushes  1 copied, 0 already there")) << sync.output;
  EXPECT_TRUE(has(sync.output, "events     1 copied, 0 already there")) << sync.output;

  const std::string commands[] = {
      "runs list",
      "runs list --json",
      "runs list --machine g1 --limit 2",
      "runs list --verdict out",
      "runs list --serial S-1",
      "runs list --status pushed --since 2020-11-21",
      "runs trend --part intake --lobe 1",
      "runs trend --part intake --lobe 1 --machine g1 --json",
      "runs trend --part intake --lobe 1 --until 2020-11-21",
      "runs spc --part intake --lobe 1",
      "runs spc --part intake --lobe 1 --machine g1 --json",
      "runs spc --part intake --lobe 2",
  };
  for (const std::string& c : commands) {
    CommandResult local = run_command(c + data_);
    CommandResult central = run_command(c + " --db " + url_);
    EXPECT_EQ(local.exit_code, 0) << c << "\n" << local.output;
    EXPECT_EQ(central.exit_code, 0) << c << "\n" << central.output;
    EXPECT_EQ(central.output, local.output) << c;
  }
  // The comparison compares something: the outputs hold the runs.
  CommandResult listed = run_command("runs list --db " + url_);
  EXPECT_TRUE(has(listed.output, "2020-11-22T08:00:00Z")) << listed.output;
  EXPECT_TRUE(has(listed.output, "g2")) << listed.output;
  CommandResult spc = run_command("runs spc --part intake --lobe 1 --db " + url_);
  EXPECT_TRUE(has(spc.output, "SPC of intake lobe 1: 4 runs")) << spc.output;

  // The trend plot draws the same picture from either.
  const std::string plot = " --part intake --lobe 1 --characteristic roundness --plot ";
  CommandResult local_plot = run_command("runs trend" + plot + (dir_ / "local.svg").string() + data_);
  CommandResult central_plot = run_command("runs trend" + plot + (dir_ / "central.svg").string() + " --db " + url_);
  ASSERT_EQ(local_plot.exit_code, 0) << local_plot.output;
  ASSERT_EQ(central_plot.exit_code, 0) << central_plot.output;
  EXPECT_TRUE(has(central_plot.output, "roundness of 4 runs plotted to")) << central_plot.output;
  const auto read = [](const std::filesystem::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string central_svg = read(dir_ / "central.svg");
  EXPECT_TRUE(has(central_svg, "<svg")) << central_svg.substr(0, 200);
  EXPECT_EQ(central_svg, read(dir_ / "local.svg"));

  // A second sync copies nothing.
  CommandResult again = run_command("plant sync --to " + url_ + data_ + " --machine cell-1");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_TRUE(has(again.output, "runs       0 copied, 0 already there (up to id 5)")) << again.output;
}

// `--per-degree` copies each run's per-degree tables and raw revolutions; a prune on the grinder
// after the sync is followed by the next one, which says so.
TEST_F(CentralCliTest, PerDegreeTablesAreCopiedAndAPruneIsFollowedAndSaid) {
  CommandResult sync = run_command("plant sync --per-degree --to " + url_ + data_ + " --machine cell-1");
  ASSERT_EQ(sync.exit_code, 0) << sync.output;
  const std::string db = url_.substr(url_.rfind('/') + 1);
  EXPECT_EQ(shared_postgres().psql(db, "SELECT count(*) FROM run_tables"), "5");
  EXPECT_EQ(shared_postgres().psql(db, "SELECT count(*) FROM run_raw"), "5");
  EXPECT_FALSE(has(sync.output, "pruned")) << sync.output;

  CommandResult prune = run_command("runs prune --raw-older-than-days 0" + data_);
  ASSERT_EQ(prune.exit_code, 0) << prune.output;
  CommandResult again = run_command("plant sync --to " + url_ + data_ + " --machine cell-1");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_TRUE(has(again.output, "5 runs pruned on the grinder since they were copied")) << again.output;
  EXPECT_EQ(shared_postgres().psql(db, "SELECT count(*) FROM run_raw"), "0");
  EXPECT_EQ(shared_postgres().psql(db, "SELECT count(*) FROM runs WHERE raw_pruned_utc IS NOT NULL"), "5");
  CommandResult local = run_command("runs list" + data_);
  CommandResult central = run_command("runs list --db " + url_);
  EXPECT_TRUE(has(local.output, "(raw pruned)")) << local.output;
  EXPECT_EQ(central.output, local.output);
}

// The central history's rows, without the time of the sync.
std::string central_contents(const std::string& url) {
  const std::string db = url.substr(url.rfind('/') + 1);
  return shared_postgres().psql(
             db, "SELECT uuid, local_id, started_utc, status, max_abs_error_um FROM runs ORDER BY uuid") +
         "\n" + shared_postgres().psql(db, "SELECT run_uuid, position, value FROM run_characteristics ORDER BY 1, 2") +
         "\n" + shared_postgres().psql(db, "SELECT uuid, run_uuid FROM nc_pushes ORDER BY uuid") + "\n" +
         shared_postgres().psql(db, "SELECT uuid FROM events ORDER BY uuid") + "\n" +
         shared_postgres().psql(db, "SELECT table_name, last_local_id FROM sync_progress ORDER BY 1");
}

TEST_F(CentralCliTest, ASyncKilledHalfWayResumesAndCopiesNothingTwice) {
  {
    Result<RunStore> store = RunStore::open(dir_ / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (int i = 0; i < 400; ++i) {
      char started[32];
      std::snprintf(started, sizeof started, "2020-12-%02dT%02d:%02d:00Z", 1 + i / 96, (i % 96) / 4, (i % 4) * 15);
      ASSERT_TRUE(store->insert_run(testing::sample_run("intake", 1 + i % 3, "g1", started, 1.0 + 0.01 * i)).ok());
    }
  }
  const std::string reference = shared_postgres().create_database();
  CommandResult whole = run_command("plant sync --to " + reference + data_ + " --machine g1");
  ASSERT_EQ(whole.exit_code, 0) << whole.output;

  // One run per transaction, killed (SIGKILL: no clean-up of any kind) once some are copied.
  const std::string db = url_.substr(url_.rfind('/') + 1);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string binary = testing::gaugeloop_binary();
    const std::string data_dir = dir_.path().string();
    std::freopen("/dev/null", "w", stdout);
    ::execl(binary.c_str(), binary.c_str(), "plant", "sync", "--to", url_.c_str(), "--data-dir", data_dir.c_str(),
            "--machine", "g1", "--batch-size", "1", static_cast<char*>(nullptr));
    std::_Exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  std::int64_t copied = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    const std::string out = shared_postgres().psql(db, "SELECT count(*) FROM runs");
    copied = std::strtoll(out.c_str(), nullptr, 10);
    if (copied >= 5) break;
  }
  ASSERT_GE(copied, 5) << "the sync copied no runs in 30 s";
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  const std::string after_kill = shared_postgres().psql(db, "SELECT count(*), count(DISTINCT uuid) FROM runs");
  // Killed mid-way (unless the machine was fast enough to finish first): what is there is
  // whole batches, each once, and the progress names the last of them.
  RecordProperty("runs_when_killed", WIFSIGNALED(status) ? after_kill : "finished before the kill");
  if (WIFSIGNALED(status)) {
    const std::int64_t there = std::strtoll(after_kill.c_str(), nullptr, 10);
    EXPECT_LT(there, 405) << after_kill;
    EXPECT_EQ(after_kill, std::to_string(there) + "|" + std::to_string(there));
    EXPECT_EQ(shared_postgres().psql(db, "SELECT max(local_id) FROM runs"),
              shared_postgres().psql(db, "SELECT last_local_id FROM sync_progress WHERE table_name = 'runs'"));
  }

  CommandResult resumed = run_command("plant sync --to " + url_ + data_ + " --machine g1");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_TRUE(has(resumed.output, ", 0 already there (up to id 405)")) << resumed.output;
  EXPECT_EQ(central_contents(url_), central_contents(reference));
  EXPECT_EQ(shared_postgres().psql(db, "SELECT count(*), count(DISTINCT uuid) FROM runs"), "405|405");
}

TEST_F(CentralCliTest, ASyncWithConfigNamesTheGrinderAsTheConfigDoes) {
  // The service's config names its machine: a sync from that config needs no --machine.
  std::ofstream(dir_ / "service.toml") << "machine = \"cell-7\"\n[database]\npath = \"gaugeloop.sqlite\"\n";
  CommandResult sync = run_command("plant sync --to " + url_ + " --config " + (dir_ / "service.toml").string());
  ASSERT_EQ(sync.exit_code, 0) << sync.output;
  EXPECT_TRUE(has(sync.output, "(machine cell-7)")) << sync.output;
  const std::string db = url_.substr(url_.rfind('/') + 1);
  EXPECT_EQ(shared_postgres().psql(db, "SELECT DISTINCT source_machine FROM runs"), "cell-7");
}

TEST_F(CentralCliTest, AServerNobodyListensOnOrABadUrlIsAClearErrorAndExitStatus) {
  const std::string port = std::to_string(testing::free_loopback_port());
  const std::string nobody = "postgresql://postgres@127.0.0.1:" + port + "/plant";
  CommandResult list = run_command("runs list --db " + nobody);
  EXPECT_EQ(list.exit_code, 4) << list.output;
  EXPECT_TRUE(has(list.output, "cannot reach the central history at host 127.0.0.1 port " + port)) << list.output;
  EXPECT_TRUE(has(list.output, "(--db)")) << list.output;
  CommandResult sync = run_command("plant sync --to " + nobody + data_ + " --machine g1");
  EXPECT_EQ(sync.exit_code, 4) << sync.output;
  EXPECT_TRUE(has(sync.output, "check that PostgreSQL runs there")) << sync.output;

  CommandResult file = run_command("runs list --db " + (dir_ / "gaugeloop.sqlite").string());
  EXPECT_EQ(file.exit_code, 2) << file.output;
  EXPECT_TRUE(has(file.output, "it is not a URL (a run database file is given with --data-dir or --config)"))
      << file.output;
  CommandResult port_text = run_command("runs spc --part intake --lobe 1 --db postgresql://central:port/plant");
  EXPECT_EQ(port_text.exit_code, 2) << port_text.output;
  EXPECT_TRUE(has(port_text.output, "the port 'port' is not 1 to 65535")) << port_text.output;

  // --db and --data-dir name two histories: the command line is refused.
  CommandResult both = run_command("runs list --db " + url_ + data_);
  EXPECT_EQ(both.exit_code, 2) << both.output;
  EXPECT_TRUE(has(both.output, "excludes")) << both.output;
  // An empty database is no central history: the query says to sync first.
  CommandResult empty = run_command("runs list --db " + url_);
  EXPECT_EQ(empty.exit_code, 4) << empty.output;
  EXPECT_TRUE(has(empty.output, "gaugeloop plant sync --to")) << empty.output;
}

}  // namespace
}  // namespace gaugeloop

// What every subcommand shares: the exit status each error code gives (documented in the
// README, relied on by scripts and the service's unit), the embedded demo part, data paths.
#include "cli/cli_common.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace gaugeloop {
namespace {

TEST(CliCommon, EveryErrorCodeHasItsDocumentedExitStatus) {
  EXPECT_EQ(exit_code_for(ErrorCode::kInvalidInput), 2);
  EXPECT_EQ(exit_code_for(ErrorCode::kNotFound), 2);
  EXPECT_EQ(exit_code_for(ErrorCode::kRefused), 2);
  EXPECT_EQ(exit_code_for(ErrorCode::kGaugeUnreachable), 3);
  EXPECT_EQ(exit_code_for(ErrorCode::kGaugeTimeout), 3);
  EXPECT_EQ(exit_code_for(ErrorCode::kGaugeProtocol), 3);
  EXPECT_EQ(exit_code_for(ErrorCode::kIncompleteRun), 3);
  EXPECT_EQ(exit_code_for(ErrorCode::kStorage), 4);
  EXPECT_EQ(exit_code_for(ErrorCode::kIo), 5);
  EXPECT_EQ(exit_code_for(ErrorCode::kInternal), 1);
  EXPECT_EQ(kExitNotPushed, 6);
}

TEST(CliCommon, TheEmbeddedPartIsTheShippedIntakeLobe) {
  Result<LoadedPart> part = load_part("");
  ASSERT_TRUE(part.ok()) << part.error().message;
  EXPECT_EQ(part->file.part.name, "intake_flat");
  EXPECT_EQ(part->file.part.lobe, 1);
  EXPECT_EQ(part->design.angle_deg.size(), 360u);
  EXPECT_EQ(part->design.source, "embedded:intake_flat.csv");
  // The same as the file in examples/, which the embedded text is built from.
  Result<LoadedPart> shipped = load_part(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/intake_flat.toml");
  ASSERT_TRUE(shipped.ok()) << shipped.error().message;
  EXPECT_EQ(shipped->design.lift_mm, part->design.lift_mm);
}

TEST(CliCommon, AMissingPartFileIsNamed) {
  Result<LoadedPart> part = load_part("/nonexistent/part.toml");
  ASSERT_FALSE(part.ok());
  EXPECT_EQ(part.error().code, ErrorCode::kNotFound);
  EXPECT_NE(part.error().message.find("/nonexistent/part.toml"), std::string::npos) << part.error().message;
}

TEST(CliCommon, DataPathsDefaultUnderTheDataDirectory) {
  DataPaths paths;
  EXPECT_EQ(paths.db(), std::filesystem::path("gaugeloop-data") / "gaugeloop.sqlite");
  EXPECT_EQ(paths.nc(), std::filesystem::path("gaugeloop-data") / "nc");
  paths.nc_dir = "/srv/nc";
  EXPECT_EQ(paths.nc(), std::filesystem::path("/srv/nc"));
  Status missing = require_database("/nonexistent/gaugeloop.sqlite", "run a demo first");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().message, "no run database at /nonexistent/gaugeloop.sqlite; run a demo first");
}

// Flag beats environment beats built-in default: the environment is the default's source.
TEST(CliCommon, TheDataDirectoryDefaultsToGaugeloopDataDirThenGaugeloopData) {
  const char* was = std::getenv("GAUGELOOP_DATA_DIR");
  const std::string saved = was != nullptr ? was : "";
  ::setenv("GAUGELOOP_DATA_DIR", "/srv/runs", 1);
  EXPECT_EQ(default_data_dir(), "/srv/runs");
  EXPECT_EQ(DataPaths().db(), std::filesystem::path("/srv/runs/gaugeloop.sqlite"));
  ::setenv("GAUGELOOP_DATA_DIR", "", 1);
  EXPECT_EQ(default_data_dir(), "gaugeloop-data") << "set but empty counts as unset";
  ::unsetenv("GAUGELOOP_DATA_DIR");
  EXPECT_EQ(default_data_dir(), "gaugeloop-data");
  if (was != nullptr) ::setenv("GAUGELOOP_DATA_DIR", saved.c_str(), 1);
}

// With --config the service's paths stand, whatever the data directory; --nc-dir still wins.
TEST(CliCommon, TheServicesConfigGivesTheDatabaseAndNcDirectory) {
  DataPaths p;
  p.data_dir = "ignored";
  p.config = "/etc/gaugeloop/gaugeloop.toml";
  p.from_config = {"/var/lib/gaugeloop/runs-7.sqlite", "/var/lib/gaugeloop/nc", "grinder-7"};
  EXPECT_EQ(p.db(), std::filesystem::path("/var/lib/gaugeloop/runs-7.sqlite"));
  EXPECT_EQ(p.nc(), std::filesystem::path("/var/lib/gaugeloop/nc"));
  EXPECT_EQ(p.where(), "--config /etc/gaugeloop/gaugeloop.toml");
  p.nc_dir = "/tmp/nc";
  EXPECT_EQ(p.nc(), std::filesystem::path("/tmp/nc"));
}

}  // namespace
}  // namespace gaugeloop

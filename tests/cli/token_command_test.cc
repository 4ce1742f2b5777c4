// `gaugeloop token new FILE` as a user runs it: the real binary, the file it leaves, and what
// it refuses.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <string>

#include "tests/support/cli.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

using testing::CommandResult;
using testing::run_command;
using testing::run_shell;
using testing::slurp;

using testing::has;

unsigned mode_of(const fs::path& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 ? (st.st_mode & 07777) : 0u;
}

bool is_lower_hex(const std::string& s) { return s.find_first_not_of("0123456789abcdef") == std::string::npos; }

TEST(TokenCommand, WritesSixtyFourRandomHexCharactersOwnerOnly) {
  testing::TempDir dir;
  const fs::path a = dir / "a";
  const fs::path b = dir / "b";
  // umask 0 would leave a file made with default permissions world-writable: the mode is ours.
  CommandResult r = run_shell("umask 0 && " + testing::gaugeloop_binary() + " token new " + a.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "wrote a new 256-bit token to " + a.string())) << r.output;
  EXPECT_TRUE(has(r.output, "token_file = \"" + a.string() + "\"")) << r.output;
  EXPECT_TRUE(has(r.output, "chown root:gaugeloop " + a.string() + "; chmod 0640 " + a.string())) << r.output;
  ASSERT_EQ(run_command("token new " + b.string()).exit_code, 0);

  EXPECT_EQ(mode_of(a), 0600u);
  EXPECT_EQ(mode_of(b), 0600u);
  const std::string token_a = slurp(a);
  const std::string token_b = slurp(b);
  ASSERT_EQ(token_a.size(), 65u) << token_a;
  EXPECT_EQ(token_a.back(), '\n');
  EXPECT_TRUE(is_lower_hex(token_a.substr(0, 64))) << token_a;
  EXPECT_TRUE(is_lower_hex(token_b.substr(0, 64))) << token_b;
  EXPECT_NE(token_a, token_b);
  EXPECT_FALSE(has(r.output, token_a.substr(0, 64))) << "the token is not printed: " << r.output;
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir.path())) ++entries;
  EXPECT_EQ(entries, 2) << "no temporary file is left";
}

TEST(TokenCommand, AnExistingFileIsKeptUnlessForced) {
  testing::TempDir dir;
  const fs::path token = dir.write("token", "the token clients use\n");
  CommandResult r = run_command("token new " + token.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, token.string() + " exists: not replaced")) << r.output;
  EXPECT_TRUE(has(r.output, "--force")) << r.output;
  EXPECT_EQ(slurp(token), "the token clients use\n");

  r = run_command("token new --force " + token.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(slurp(token).size(), 65u);
  EXPECT_EQ(mode_of(token), 0600u);

  r = run_command("token new " + (dir / "no-such-dir" / "token").string());
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "no-such-dir")) << r.output;
}

// The token the command makes is one the service takes; the same file opened to every user is
// refused by `serve --check` and by `serve` itself, before it listens.
TEST(TokenCommand, TheServiceTakesTheNewTokenAndRefusesItWhenOthersCanReadIt) {
  testing::TempDir dir;
  const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
  const fs::path config =
      dir.write("gaugeloop.toml", "[gauge]\n[[part]]\nfile = \"" + (examples / "intake_flat.toml").string() +
                                      "\"\n[nc]\ntemplate = \"" + (examples / "sinumerik" / "cam_table.spf").string() +
                                      "\"\n[http]\nport = 0\ntoken_file = \"token\"\n");
  ASSERT_EQ(run_command("token new " + (dir / "token").string()).exit_code, 0);
  CommandResult r = run_command("serve --check --config " + config.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;

  fs::permissions(dir / "token", fs::perms::others_read, fs::perm_options::add);
  const std::string refusal = config.string() + ":8: key `http.token_file`: HTTP token file " +
                              (dir / "token").string() + " can be read by any user (mode 0604)";
  r = run_command("serve --check --config " + config.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, refusal)) << r.output;
  // A service that started would wait for a signal: the guard kills it, and the test fails.
  r = run_shell("timeout -s KILL 120 " + testing::gaugeloop_binary() + " serve --config " + config.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, refusal)) << r.output;
  EXPECT_FALSE(has(r.output, "listening on")) << r.output;
}

}  // namespace
}  // namespace gaugeloop

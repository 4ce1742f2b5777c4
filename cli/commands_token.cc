// token: the secret an HTTP client shows to write (measure, approve, roll back), made here so
// that nobody has to invent one.
#include <sys/random.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "cli/cli_common.h"
#include "core/atomic_file.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

constexpr size_t kTokenBytes = 32;  // 256 bits, written as 64 hex characters

// `count` bytes from the kernel's random generator (getrandom(2), which blocks only until the
// generator is seeded at boot).
Result<std::string> random_bytes(size_t count) {
  std::string bytes(count, '\0');
  size_t done = 0;
  while (done < count) {
    const ssize_t n = ::getrandom(bytes.data() + done, count - done, 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      return make_error(ErrorCode::kInternal,
                        std::string("cannot read random bytes (getrandom): ") + std::strerror(errno));
    }
    done += static_cast<size_t>(n);
  }
  return bytes;
}

struct TokenOptions {
  std::string file;
  bool force = false;
};

int cmd_token_new(const TokenOptions& o) {
  const fs::path file = fs::absolute(o.file).lexically_normal();
  std::error_code ec;
  // Checked before writing: the write itself replaces. Between the two another process could
  // create the file; a person running this command is not racing one.
  if (!o.force && fs::symlink_status(file, ec).type() != fs::file_type::not_found) {
    return report_error(
        make_error(ErrorCode::kRefused, file.string() + " exists: not replaced, as clients may use the token in it; "
                                                        "give --force to replace it"));
  }
  Result<std::string> bytes = random_bytes(kTokenBytes);
  if (!bytes) return report_error(bytes.error());
  static constexpr char kHex[] = "0123456789abcdef";
  std::string token;
  for (unsigned char b : *bytes) {
    token += kHex[b >> 4];
    token += kHex[b & 0x0f];
  }
  if (Status s = write_file_atomically(file, token + "\n", {}, 0600); !s) return report_error(s.error());
  std::printf(
      "wrote a new 256-bit token to %s (mode 0600)\n"
      "give it to the service in its config:\n"
      "  [http]\n"
      "  token_file = \"%s\"\n"
      "let the service's group read it, and nobody else:\n"
      "  chown root:gaugeloop %s; chmod 0640 %s\n"
      "then reload the service (systemctl reload gaugeloop, or SIGHUP): the new token is in force at once\n",
      file.c_str(), file.c_str(), file.c_str(), file.c_str());
  return kExitOk;
}

}  // namespace

void add_token_commands(CLI::App& app, CommandAction& action) {
  CLI::App* token = app.add_subcommand("token", "The token HTTP clients show to write (measure, approve, roll back).");
  token->require_subcommand(1);
  auto o = std::make_shared<TokenOptions>();
  CLI::App* new_cmd = token->add_subcommand(
      "new",
      "Write a new random 256-bit token (64 hex characters) to FILE, readable by its owner only (mode 0600), "
      "and say how to configure it. An existing FILE is kept unless --force.");
  new_cmd->add_option("file", o->file, "Where to write it, e.g. /etc/gaugeloop/token")->required();
  new_cmd->add_flag("--force", o->force, "Replace FILE if it exists");
  new_cmd->callback([&action, o] { action = [o] { return cmd_token_new(*o); }; });
}

}  // namespace gaugeloop

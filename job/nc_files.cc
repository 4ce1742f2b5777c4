// The real NC directory.
#include "job/nc_files.h"

#include "core/text_file.h"

namespace gaugeloop {
namespace {

class RealNcFiles final : public NcFiles {
 public:
  Result<DirectoryLock> lock_directory(const std::filesystem::path& dir) override {
    return DirectoryLock::acquire(dir);
  }
  bool is_directory(const std::filesystem::path& dir) override {
    std::error_code ec;
    return std::filesystem::is_directory(dir, ec);
  }
  Result<std::optional<std::string>> read_program(const std::filesystem::path& path) override {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) return std::optional<std::string>();
    Result<std::string> text = read_regular_file(path, "NC program");
    if (!text) return text.error();
    return std::optional<std::string>(std::move(*text));
  }
  Status write_program(const std::filesystem::path& path, std::string_view contents,
                       const AtomicWriteObserver& observer) override {
    return write_file_atomically(path, contents, observer);
  }
  Result<int> remove_leftovers(const std::filesystem::path& path) override { return remove_atomic_leftovers(path); }
};

}  // namespace

NcFiles& real_nc_files() {
  static RealNcFiles files;
  return files;
}

Status write_program_read_back(NcFiles& files, const std::filesystem::path& path, std::string_view text,
                               std::string_view what) {
  if (Status s = files.write_program(path, text, {}); !s) {
    return make_error(s.error().code, path.string() + ": the " + std::string(what) + " was not written (" +
                                          s.error().message + "); the one on the control, if any, stays");
  }
  Result<std::optional<std::string>> back = files.read_program(path);
  if (!back) return back.error();
  if (!*back || **back != text) {
    return make_error(ErrorCode::kRefused, path.string() + ": the " + std::string(what) +
                                               " read back differs from the one written; check the NC directory "
                                               "(a share that rewrites files?) and push again");
  }
  return {};
}

}  // namespace gaugeloop

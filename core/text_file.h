// Reading an input file whole, only when it is a regular file of a sensible size.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/result.h"

namespace gaugeloop {

// The largest input gaugeloop reads whole: part files, lift tables, gauge and service
// configs, NC templates and programs are all far smaller (a 0.1 deg lift table is ~100 KB).
constexpr std::size_t kMaxInputFileBytes = 16u * 1024u * 1024u;

// Reads `path` whole. `what` names it in messages ("lift table", "NC template"). Refuses,
// before reading a byte: a missing file (kNotFound), anything but a regular file after
// following links (a directory, a device such as /dev/zero, a FIFO: kInvalidInput), and a
// file larger than `max_bytes` (kInvalidInput). kIo if it cannot be read. Every message
// names the file and says what to do.
Result<std::string> read_regular_file(const std::filesystem::path& path, std::string_view what,
                                      std::size_t max_bytes = kMaxInputFileBytes);

// `text` without a leading UTF-8 byte order mark (EF BB BF), as spreadsheet programs and
// Windows editors write one.
std::string_view without_utf8_bom(std::string_view text);

}  // namespace gaugeloop

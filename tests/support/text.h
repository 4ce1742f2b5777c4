// Small helpers on text and files that test files share.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace gaugeloop::testing {

// Whether `text` holds `fragment` anywhere.
inline bool has(const std::string& text, const std::string& fragment) {
  return text.find(fragment) != std::string::npos;
}

// The whole file, bytes as they are; empty if it cannot be read.
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A program template shipped in examples/sinumerik/.
inline std::string shipped(const std::string& name) {
  return slurp(std::filesystem::path(GAUGELOOP_SOURCE_DIR) / "examples" / "sinumerik" / name);
}

}  // namespace gaugeloop::testing

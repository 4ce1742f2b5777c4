// What the readers of the service configuration share (config/service_config*.cc): the file
// being read and its relative paths. Internal to config/.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "config/service_config.h"
#include "config/toml_reader.h"
#include "core/text_file.h"

namespace gaugeloop::config_internal {

namespace fs = std::filesystem;

inline fs::path relative_to(const fs::path& base_dir, const std::string& p) {
  const fs::path path(p);
  return path.is_absolute() ? path : (base_dir / path).lexically_normal();
}

inline Result<std::string> read_text(const fs::path& path, const std::string& what) {
  Result<std::string> text = read_regular_file(path, what);
  if (!text) return text.error();
  return std::string(without_utf8_bom(*text));
}

// The file being read: its name for messages and the directory its relative paths are in.
struct ConfigFile {
  std::string source;
  fs::path base;

  fs::path resolve(const std::string& p) const { return relative_to(base, p); }
};

// [http]: address, token and TLS files of the HTTP API, and the history its lists read (the
// service's file, or `central`: the [plant.central] history); absent table, no API.
Result<std::optional<HttpSettings>> read_http_table(TomlReader& top, const ConfigFile& f,
                                                    const std::optional<CentralSyncSettings>& central);

// [plc]: the link settings of a gauge config's [link], plus where the block is and how often
// it is polled; absent table, no PLC trigger.
Result<std::optional<PlcSettings>> read_plc_table(TomlReader& top, const ConfigFile& f);

// [plant]: the plant's broker ([plant.mqtt]) and central history ([plant.central]), each
// optional.
Status read_plant_table(TomlReader& top, const ConfigFile& f, ServiceConfig& c);

}  // namespace gaugeloop::config_internal

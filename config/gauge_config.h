// Gauge config files: how to reach the amplifier and where it keeps each value (docs/gauge.md).
#pragma once

#include <filesystem>
#include <string_view>

#include "acquisition/modbus_gauge.h"
#include "core/result.h"

namespace gaugeloop {

class TomlReader;

// Reads the Modbus link keys of one table onto `out`: transport ("tcp" or "rtu"), host and
// port (TCP), device, baud, parity, data_bits and stop_bits (RTU), unit_id,
// response_timeout_ms; keys it leaves out keep `defaults`' values. A TCP key in an RTU link or
// the other way round fails `lr`, and so does a host name that does not resolve ("check the
// <device>'s address"). The caller lists these keys in its allow_only.
void read_modbus_link(TomlReader& lr, const ModbusSettings& defaults, ModbusSettings& out,
                      std::string_view device = "gauge");

// Parses a gauge config. A missing [link] keeps `defaults`' link settings; a missing [map]
// keeps the simulator's register map; a [map] describes the whole map (fields it leaves out
// are absent, and reading and angle are required). Errors name the file, line and key.
Result<ModbusSettings> parse_gauge_toml(std::string_view text, std::string_view source_name,
                                        const ModbusSettings& defaults = {});

Result<ModbusSettings> read_gauge_file(const std::filesystem::path& path, const ModbusSettings& defaults = {});

}  // namespace gaugeloop

// A strict reader of AQDEF (.dfq) files written in the K-field form, for the tests: every line
// "Kxxxx value" or "Kxxxx/n value" ending in CRLF, parsed into parts, characteristics and
// values with every K-field kept as text. Written from the public format description, not
// from the writer, so a test can tell the two apart.
#pragma once

#include <cstddef>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace gaugeloop::testing {

// The K-fields of one value (K0001 opens it; K0002.. follow it) of one characteristic.
struct DfqValue {
  std::map<std::string, std::string> fields;  // "K0001" -> "1.250"
};

struct DfqCharacteristic {
  int number = 0;                             // the n of K2xxx/n, 1-based across the file
  int part = 0;                               // the part block it follows, 1-based
  std::map<std::string, std::string> fields;  // "K2001" -> "lift_error"
  std::vector<DfqValue> values;               // in file order
};

struct DfqPart {
  int number = 0;  // the n of K1xxx/n
  std::map<std::string, std::string> fields;
  std::vector<int> characteristics;  // their numbers, in file order
};

struct DfqFile {
  int total_characteristics = 0;  // K0100
  std::vector<DfqPart> parts;
  std::vector<DfqCharacteristic> characteristics;  // [n - 1] is number n
};

namespace dfq_detail {

inline Error line_error(std::size_t line, const std::string& what) {
  return make_error(ErrorCode::kInvalidInput, "line " + std::to_string(line) + ": " + what);
}

}  // namespace dfq_detail

// Refuses (kInvalidInput "line N: ...") a line without CRLF, a line that is not a K-field, a
// field given twice for the same part, characteristic or value, a part or characteristic
// number out of sequence, a value field before its K0001, /0 (all characteristics, not used
// by our files), the compact value form, and a K0100 missing or not matching the count.
inline Result<DfqFile> read_dfq(std::string_view text) {
  using dfq_detail::line_error;
  DfqFile file;
  bool have_total = false;
  std::size_t line_number = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    ++line_number;
    const std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) return line_error(line_number, "no line end after the last line");
    if (end == pos || text[end - 1] != '\r') return line_error(line_number, "line ends in LF without CR");
    const std::string_view line = text.substr(pos, end - 1 - pos);
    pos = end + 1;

    if (line.size() < 6 || line[0] != 'K') {
      return line_error(line_number, "not a K-field line (the compact value form is not read)");
    }
    for (std::size_t i = 1; i < 5; ++i) {
      if (line[i] < '0' || line[i] > '9') return line_error(line_number, "the K-field number is not 4 digits");
    }
    const std::string key(line.substr(0, 5));
    std::size_t at = 5;
    int index = -1;
    if (line[at] == '/') {
      ++at;
      index = 0;
      const std::size_t digits_from = at;
      while (at < line.size() && line[at] >= '0' && line[at] <= '9' && at - digits_from < 6) {
        index = index * 10 + (line[at] - '0');
        ++at;
      }
      if (at == digits_from) return line_error(line_number, "no number after '/'");
      if (index == 0) return line_error(line_number, "/0 (all characteristics) is not read");
    }
    if (at >= line.size() || line[at] != ' ') return line_error(line_number, "no space after the K-field");
    const std::string value(line.substr(at + 1));

    const char group = key[1];
    if (key == "K0100") {
      if (index != -1) return line_error(line_number, "K0100 takes no number");
      if (have_total) return line_error(line_number, "K0100 given twice");
      try {
        std::size_t used = 0;
        file.total_characteristics = std::stoi(value, &used);
        if (used != value.size()) throw std::invalid_argument(value);
      } catch (const std::exception&) {
        return line_error(line_number, "K0100 \"" + value + "\" is not a number");
      }
      have_total = true;
    } else if (group == '1') {
      if (index == -1) return line_error(line_number, key + " without a part number");
      if (index == static_cast<int>(file.parts.size()) + 1) {
        file.parts.push_back(DfqPart{index, {}, {}});
      } else if (index < 1 || index > static_cast<int>(file.parts.size())) {
        return line_error(line_number, key + "/" + std::to_string(index) + ": part number out of sequence");
      }
      DfqPart& part = file.parts[static_cast<std::size_t>(index - 1)];
      if (!part.fields.emplace(key, value).second) return line_error(line_number, key + " given twice for a part");
    } else if (group == '2') {
      if (file.parts.empty()) return line_error(line_number, key + " before any part (K1001)");
      if (index == -1) return line_error(line_number, key + " without a characteristic number");
      if (index == static_cast<int>(file.characteristics.size()) + 1) {
        DfqCharacteristic c;
        c.number = index;
        c.part = file.parts.back().number;
        file.characteristics.push_back(c);
        file.parts.back().characteristics.push_back(index);
      } else if (index < 1 || index > static_cast<int>(file.characteristics.size())) {
        return line_error(line_number, key + "/" + std::to_string(index) + ": characteristic number out of sequence");
      }
      DfqCharacteristic& c = file.characteristics[static_cast<std::size_t>(index - 1)];
      if (!c.fields.emplace(key, value).second) {
        return line_error(line_number, key + " given twice for characteristic " + std::to_string(index));
      }
    } else if (group == '0') {
      if (index == -1) return line_error(line_number, key + " without a characteristic number");
      if (index > static_cast<int>(file.characteristics.size())) {
        return line_error(line_number, key + "/" + std::to_string(index) + ": no such characteristic");
      }
      DfqCharacteristic& c = file.characteristics[static_cast<std::size_t>(index - 1)];
      if (key == "K0001") {
        c.values.push_back(DfqValue{});
      } else if (c.values.empty()) {
        return line_error(line_number, key + " before the K0001 of its value");
      }
      if (!c.values.back().fields.emplace(key, value).second) {
        return line_error(line_number, key + " given twice for one value");
      }
    } else {
      return line_error(line_number, key + " is not a field this reader knows");
    }
  }
  if (!have_total) return make_error(ErrorCode::kInvalidInput, "no K0100 (number of characteristics)");
  if (file.total_characteristics != static_cast<int>(file.characteristics.size())) {
    return make_error(ErrorCode::kInvalidInput, "K0100 says " + std::to_string(file.total_characteristics) +
                                                    " characteristics, the file describes " +
                                                    std::to_string(file.characteristics.size()));
  }
  return file;
}

}  // namespace gaugeloop::testing

// A strict RFC 4180 reader for the tests: records end in CRLF, fields are separated by commas,
// a quoted field may hold commas, CR, LF and doubled quotes. Written here rather than trusting
// the writer's own idea of CSV, so the export is checked against the RFC.
#pragma once

#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace gaugeloop::testing {

using CsvRecord = std::vector<std::string>;

// The records of `text`, or nullopt when it is not RFC 4180 with CRLF line ends (a bare CR or
// LF outside quotes, a quote inside an unquoted field, an unclosed quote, text after a closing
// quote, or a last record without its CRLF).
inline std::optional<std::vector<CsvRecord>> read_csv(const std::string& text) {
  std::vector<CsvRecord> records;
  CsvRecord record;
  std::string field;
  std::size_t i = 0;
  while (i < text.size()) {
    if (text[i] == '"') {
      for (++i;; ++i) {
        if (i >= text.size()) return std::nullopt;  // unclosed quote
        if (text[i] == '"') {
          if (i + 1 < text.size() && text[i + 1] == '"') {
            field += '"';
            ++i;
          } else {
            ++i;
            break;
          }
        } else {
          field += text[i];
        }
      }
    } else {
      while (i < text.size() && text[i] != ',' && text[i] != '\r' && text[i] != '\n') {
        if (text[i] == '"') return std::nullopt;
        field += text[i++];
      }
    }
    record.push_back(field);
    field.clear();
    if (i < text.size() && text[i] == ',') {
      ++i;
      continue;
    }
    if (text.compare(i, 2, "\r\n") != 0) return std::nullopt;  // bare CR/LF, junk, or no final CRLF
    i += 2;
    records.push_back(record);
    record.clear();
  }
  if (!record.empty()) return std::nullopt;
  return records;
}

// A table of numbers as `profile` writes it: one header line, then rows of numbers separated by
// commas, lines ending in LF. std::stod throws on a cell that is not a number, failing the test.
struct NumericCsv {
  std::string header;
  std::vector<std::vector<double>> rows;
};
inline NumericCsv read_numeric_csv(const std::string& text) {
  NumericCsv csv;
  std::istringstream in(text);
  std::getline(in, csv.header);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::istringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ',')) row.push_back(std::stod(cell));
    csv.rows.push_back(row);
  }
  return csv;
}

}  // namespace gaugeloop::testing

// The AQDEF (.dfq) writer: description lines first (K0100, the part blocks and their
// characteristics), then the values run by run, every field on its own "Kxxxx/n value" line.
#include "report/dfq.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string_view>
#include <tuple>
#include <utility>

#include "core/number_text.h"
#include "core/utc_time.h"
#include "core/utf8.h"
#include "report/judged_error.h"

namespace gaugeloop {
namespace {

constexpr std::string_view kCrLf = "\r\n";

// Decimals written for a unit, also K2022: 1 nm for um, 0.0001 deg for a timing error, and
// enough for the velocity and acceleration errors' small figures.
int dfq_decimals(const std::string& unit) {
  if (unit == "um") return 3;
  if (unit == "deg") return 4;
  if (unit == "mm/deg") return 6;
  if (unit == "mm/deg^2") return 8;
  return 6;
}

bool is_harmonic(const std::string& key) { return key.rfind(kHarmonicKeyPrefix, 0) == 0; }

// The harmonic order of "harmonic.<k>", 0 if the rest is not a number.
int harmonic_order(const std::string& key) {
  int k = 0;
  for (char c : key.substr(kHarmonicKeyPrefix.size())) {
    if (c < '0' || c > '9' || k > 1000) return 0;
    k = k * 10 + (c - '0');
  }
  return k;
}

// Figures that cannot be below 0: their lower boundary is natural, not a tolerance. A gear's
// F_beta, f_f_beta, F_alpha and f_f_alpha are widths of bands; f_H_beta and f_H_alpha are signed
// (their means over the flanks, sizes, are not).
bool has_natural_zero(const std::string& key) {
  return key == "base_circle_runout" || key == "base_circle_runout_h1" || key == "roundness" || is_harmonic(key) ||
         key.rfind("lead.F_beta", 0) == 0 || key.rfind("lead.f_f_beta", 0) == 0 || key == "lead.f_H_beta.mean_abs" ||
         key.rfind("profile.F_alpha", 0) == 0 || key.rfind("profile.f_f_alpha", 0) == 0 ||
         key == "profile.f_H_alpha.mean_abs";
}

std::string run_name(const RunSummary& r) { return "run " + std::to_string(r.id); }

// The Windows-1252 byte of a code point, or 0 if it has none: Latin-1's printable range
// (U+00A0..U+00FF, umlauts, accents, the sharp s) is itself; 0x80..0x9F hold a few more (the
// euro sign, typographic quotes, Š, Œ, Ž...).
unsigned char windows_1252_byte(char32_t cp) {
  if (cp >= 0x20 && cp <= 0x7e) return static_cast<unsigned char>(cp);
  if (cp >= 0xa0 && cp <= 0xff) return static_cast<unsigned char>(cp);
  static constexpr char32_t kHigh[32] = {0x20ac, 0,      0x201a, 0x0192, 0x201e, 0x2026, 0x2020, 0x2021,
                                         0x02c6, 0x2030, 0x0160, 0x2039, 0x0152, 0,      0x017d, 0,
                                         0,      0x2018, 0x2019, 0x201c, 0x201d, 0x2022, 0x2013, 0x2014,
                                         0x02dc, 0x2122, 0x0161, 0x203a, 0x0153, 0,      0x017e, 0x0178};
  for (int i = 0; i < 32; ++i) {
    if (kHigh[i] != 0 && kHigh[i] == cp) return static_cast<unsigned char>(0x80 + i);
  }
  return 0;
}

// `text` (UTF-8, as gaugeloop keeps it) in Windows-1252, the encoding Q-DAS tools read a .dfq
// in, within the K-field's length (in characters). Refused, naming the run, the field and the
// character: a control character (a line break would end the K-field line), bytes that are not
// UTF-8, or a character Windows-1252 has no byte for (a transliterated name would no longer
// match its part).
Result<std::string> dfq_text(std::string_view text, std::string_view field, std::size_t max_length,
                             const std::string& where) {
  std::string out;
  for (std::size_t i = 0; i < text.size();) {
    char32_t cp = 0;
    const std::size_t n = utf8_sequence_at(text, i, cp);
    const unsigned char byte = n == 0 ? 0 : windows_1252_byte(cp);
    if (byte == 0) {
      const std::string what = n == 0 ? "a byte that is not UTF-8"
                               : cp < 0x20 || cp == 0x7f
                                   ? "a control character"
                                   : "\"" + std::string(text.substr(i, n)) + "\", which Windows-1252 has no byte for";
      return make_error(ErrorCode::kInvalidInput,
                        where + ": " + std::string(field) + " \"" + std::string(text) + "\" has " + what +
                            " at character " + std::to_string(out.size() + 1) +
                            "; the DFQ file (Windows-1252, as Q-DAS tools read it) cannot carry it unchanged, and a "
                            "transliterated name would no longer match its part; leave the run out of the "
                            "selection (--since/--until)");
    }
    out += static_cast<char>(byte);
    i += n;
  }
  if (out.size() > max_length) {
    return make_error(ErrorCode::kInvalidInput, where + ": " + std::string(field) + " \"" + std::string(text) +
                                                    "\" is longer than the " + std::to_string(max_length) +
                                                    " characters the K-field takes");
  }
  return out;
}

Status check_text(std::string_view text, std::string_view field, std::size_t max_length, const std::string& where) {
  Result<std::string> t = dfq_text(text, field, max_length, where);
  if (!t) return t.error();
  return {};
}

// A text check_text passed, as the file carries it.
std::string in_windows_1252(std::string_view text) {
  Result<std::string> t = dfq_text(text, "text", text.size(), "");
  return t ? *t : std::string(text);
}

// "2026-11-22T02:34:44Z" -> "22.11.2026/02:34:44".
std::optional<std::string> dfq_time(const std::string& utc) {
  if (!is_utc_timestamp(utc) || utc.size() != 20) return std::nullopt;
  return utc.substr(8, 2) + "." + utc.substr(5, 2) + "." + utc.substr(0, 4) + "/" + utc.substr(11, 8);
}

struct DfqCharacteristicDef {
  std::string key;
  std::string unit;
  Limits limits;
  int number = 0;  // 1-based across the file
};

struct PartBlock {
  std::string part;
  int lobe = 1;
  std::vector<const RunCharacteristics*> runs;  // oldest first
  std::vector<DfqCharacteristicDef> characteristics;
  std::map<std::string, std::size_t> index_of_key;
};

bool wanted(const Characteristic& c, const DfqOptions& options) {
  if (!is_harmonic(c.key)) return true;
  const int k = harmonic_order(c.key);
  return k >= 1 && k <= options.harmonics;
}

class Lines {
 public:
  void add(std::string_view key, std::optional<int> index, std::string_view value) {
    text_ += key;
    if (index) {
      text_ += '/';
      text_ += std::to_string(*index);
    }
    text_ += ' ';
    text_ += value;
    text_ += kCrLf;
  }
  std::string take() { return std::move(text_); }

 private:
  std::string text_;
};

}  // namespace

std::vector<Characteristic> harmonic_characteristics(const LobeAnalysis& analysis, int count) {
  std::vector<Characteristic> out;
  for (int k = 1; k <= std::min(count, kMaxDfqHarmonics); ++k) {
    Characteristic c;
    c.key = std::string(kHarmonicKeyPrefix) + std::to_string(k);
    c.unit = "um";
    c.value = analysis.harmonic_amplitude_um[static_cast<std::size_t>(k)];
    c.min = c.value;
    c.max = c.value;
    out.push_back(std::move(c));
  }
  return out;
}

Result<std::string> write_dfq(const std::vector<RunCharacteristics>& runs, const DfqOptions& options) {
  if (runs.empty()) return make_error(ErrorCode::kInvalidInput, "no runs to export");
  if (options.harmonics < 0 || options.harmonics > kMaxDfqHarmonics) {
    return make_error(ErrorCode::kInvalidInput, "harmonics " + std::to_string(options.harmonics) +
                                                    " is out of range; give 0 to " + std::to_string(kMaxDfqHarmonics));
  }
  if (Status s = check_text(options.operation, "operation (K1086)", 40, "the export"); !s) return s.error();

  std::vector<const RunCharacteristics*> ordered;
  for (const RunCharacteristics& r : runs) ordered.push_back(&r);
  std::stable_sort(ordered.begin(), ordered.end(), [](const RunCharacteristics* a, const RunCharacteristics* b) {
    return std::tie(a->run.started_utc, a->run.id) < std::tie(b->run.started_utc, b->run.id);
  });

  // Part blocks in the order of their oldest run; characteristics in first-seen order.
  std::vector<PartBlock> blocks;
  for (const RunCharacteristics* r : ordered) {
    const std::string where = run_name(r->run);
    if (Status s = check_text(r->run.part, "part (K1001)", 30, where); !s) return s.error();
    if (Status s = check_text(r->run.machine, "machine (K0010)", 24, where); !s) return s.error();
    if (Status s = check_text(r->run.operator_name, "operator (K0008)", 64, where); !s) return s.error();
    if (Status s = check_text(r->run.serial, "serial (K0014)", 40, where); !s) return s.error();
    if (!dfq_time(r->run.started_utc)) {
      return make_error(ErrorCode::kInvalidInput,
                        where + ": start time \"" + r->run.started_utc + "\" is not YYYY-MM-DDTHH:MM:SSZ");
    }
    auto block = std::find_if(blocks.begin(), blocks.end(),
                              [&](const PartBlock& b) { return b.part == r->run.part && b.lobe == r->run.lobe; });
    if (block == blocks.end()) {
      blocks.push_back(PartBlock{r->run.part, r->run.lobe, {}, {}, {}});
      block = blocks.end() - 1;
    }
    block->runs.push_back(r);
    for (const Characteristic& c : r->characteristics) {
      if (!wanted(c, options)) continue;
      const std::string what = where + ", characteristic " + c.key;
      if (Status s = check_text(c.key, "characteristic key (K2001)", 40, where); !s) return s.error();
      if (Status s = check_text(c.unit, "unit (K2142)", 20, what); !s) return s.error();
      if (!std::isfinite(c.value)) return make_error(ErrorCode::kInvalidInput, what + ": the value is not finite");
      if ((c.limits.lower && !std::isfinite(*c.limits.lower)) || (c.limits.upper && !std::isfinite(*c.limits.upper))) {
        return make_error(ErrorCode::kInvalidInput, what + ": a limit is not finite; correct the part's tolerances");
      }
      auto found = block->index_of_key.find(c.key);
      if (found == block->index_of_key.end()) {
        block->index_of_key.emplace(c.key, block->characteristics.size());
        block->characteristics.push_back(DfqCharacteristicDef{c.key, c.unit, c.limits, 0});
        continue;
      }
      DfqCharacteristicDef& def = block->characteristics[found->second];
      if (def.unit != c.unit) {
        return make_error(ErrorCode::kInvalidInput, what + ": unit \"" + c.unit + "\" where older runs have \"" +
                                                        def.unit + "\"; export the runs of each unit apart");
      }
      def.limits = c.limits;  // the newest run's limits win
    }
  }

  int total = 0;
  for (PartBlock& b : blocks) {
    if (b.characteristics.empty()) {
      return make_error(ErrorCode::kInvalidInput,
                        "no characteristics recorded for part " + b.part + " lobe " + std::to_string(b.lobe) +
                            " in the runs chosen (runs measured before the part file had tolerances have none)");
    }
    for (DfqCharacteristicDef& d : b.characteristics) d.number = ++total;
  }

  Lines out;
  out.add("K0100", std::nullopt, std::to_string(total));
  for (std::size_t p = 0; p < blocks.size(); ++p) {
    const PartBlock& b = blocks[p];
    const int part_number = static_cast<int>(p) + 1;
    out.add("K1001", part_number, in_windows_1252(b.part));
    // A part block is one part and lobe (or pin, or a gear's teeth): its newest run tells which.
    const PartKind kind = part_kind_of(b.runs.back()->characteristics);
    out.add("K1002", part_number,
            kind == PartKind::kGear  ? std::string("gear teeth")
            : kind == PartKind::kPin ? "pin " + std::to_string(b.lobe)
                                     : "lobe " + std::to_string(b.lobe));
    const bool one_machine = std::all_of(b.runs.begin(), b.runs.end(), [&](const RunCharacteristics* r) {
      return r->run.machine == b.runs.front()->run.machine;
    });
    if (one_machine && !b.runs.front()->run.machine.empty())
      out.add("K1081", part_number, in_windows_1252(b.runs.front()->run.machine));
    if (!options.operation.empty()) out.add("K1086", part_number, in_windows_1252(options.operation));
    // The curve the error characteristics judge, named in their title when every run of the
    // block says the same (the plant's central history does not say).
    std::optional<std::string_view> judged;
    if (std::all_of(b.runs.begin(), b.runs.end(), [&](const RunCharacteristics* r) {
          return r->run.lift_error_reference && r->run.lift_error_reference == b.runs.front()->run.lift_error_reference;
        })) {
      judged = judged_reference_text(kind, *b.runs.front()->run.lift_error_reference);
    }
    for (const DfqCharacteristicDef& d : b.characteristics) {
      const int decimals = dfq_decimals(d.unit);
      std::optional<double> lower = d.limits.lower;
      bool natural_lower = false;
      if (!lower && has_natural_zero(d.key)) {
        lower = 0.0;
        natural_lower = true;
      }
      out.add("K2001", d.number, d.key);
      out.add("K2002", d.number,
              characteristic_title(d.key, kind) +
                  (judged && judges_error_curve(d.key, kind) ? " (" + std::string(*judged) + ")" : ""));
      out.add("K2022", d.number, std::to_string(decimals));
      out.add("K2101", d.number, format_fixed(0.0, decimals));
      if (lower) out.add("K2110", d.number, format_fixed(*lower, decimals));
      if (d.limits.upper) out.add("K2111", d.number, format_fixed(*d.limits.upper, decimals));
      out.add("K2120", d.number, natural_lower ? "1" : "0");
      out.add("K2121", d.number, "0");
      out.add("K2142", d.number, d.unit);
    }
  }
  for (const RunCharacteristics* r : ordered) {
    const PartBlock& b = *std::find_if(blocks.begin(), blocks.end(), [&](const PartBlock& x) {
      return x.part == r->run.part && x.lobe == r->run.lobe;
    });
    const std::string time = *dfq_time(r->run.started_utc);
    // Every characteristic of the block, in its order: Q-DAS lines up the n-th values of a
    // block's characteristics as one part, so a characteristic the run lacks gets a
    // placeholder (K0002 255, not shown or counted) rather than no value.
    std::map<std::string, const Characteristic*> of_key;
    for (const Characteristic& c : r->characteristics) {
      if (wanted(c, options)) of_key.emplace(c.key, &c);
    }
    for (const DfqCharacteristicDef& def : b.characteristics) {
      const int i = def.number;
      const auto found = of_key.find(def.key);
      const bool measured = found != of_key.end();
      out.add("K0001", i, format_fixed(measured ? found->second->value : 0.0, dfq_decimals(def.unit)));
      out.add("K0002", i, measured ? "0" : "255");
      out.add("K0004", i, time);
      out.add("K0006", i, std::to_string(r->run.id));
      if (!r->run.operator_name.empty()) out.add("K0008", i, in_windows_1252(r->run.operator_name));
      if (!r->run.machine.empty()) out.add("K0010", i, in_windows_1252(r->run.machine));
      if (!r->run.serial.empty()) out.add("K0014", i, in_windows_1252(r->run.serial));
    }
  }
  return out.take();
}

}  // namespace gaugeloop

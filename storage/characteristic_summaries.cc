// CharacteristicSummer: the two-pass mean and squared deviations of each key, as RunHistory's
// characteristic_summaries documents them.
#include "storage/characteristic_summaries.h"

#include <algorithm>
#include <utility>

namespace gaugeloop {

void CharacteristicSummer::add(std::int64_t run_id, const Characteristic& c) {
  auto [it, inserted] = index_.try_emplace(c.key, by_key_.size());
  if (inserted) {
    by_key_.emplace_back();
    by_key_.back().key = c.key;
    values_.emplace_back();
  }
  CharacteristicSummary& k = by_key_[it->second];
  if (!inserted && (k.limits.lower != c.limits.lower || k.limits.upper != c.limits.upper)) k.limits_changed = true;
  values_[it->second].push_back(c.value);
  k.unit = c.unit;
  k.limits = c.limits;
  k.limits_from_run = run_id;
  if (c.verdict != Verdict::kNotJudged) ++k.judged_count;
  if (c.verdict == Verdict::kOut) ++k.out_count;
}

CharacteristicSummaries CharacteristicSummer::finish(int runs, std::string first_started_utc,
                                                     std::string last_started_utc) {
  for (std::size_t i = 0; i < by_key_.size(); ++i) {
    CharacteristicSummary& k = by_key_[i];
    const std::vector<double>& v = values_[i];
    k.n = static_cast<int>(v.size());
    k.all_equal = std::all_of(v.begin(), v.end(), [&](double x) { return x == v.front(); });
    k.mean = 0.0;
    for (double x : v) k.mean += x / static_cast<double>(k.n);  // no overflow before the division
    if (k.all_equal) k.mean = v.front();
    k.squares = 0.0;
    if (!k.all_equal) {
      for (double x : v) k.squares += (x - k.mean) * (x - k.mean);
    }
  }
  CharacteristicSummaries out;
  out.runs = runs;
  out.first_started_utc = std::move(first_started_utc);
  out.last_started_utc = std::move(last_started_utc);
  out.by_key = std::move(by_key_);
  index_.clear();
  values_.clear();
  by_key_.clear();
  return out;
}

}  // namespace gaugeloop

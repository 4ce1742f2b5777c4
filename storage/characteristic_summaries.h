// Summing up the characteristics of a window of runs key by key, as `runs spc` reads them:
// the file streams the window's rows in one statement into a CharacteristicSummer; the central
// history sums them up in PostgreSQL (plant/central_history.cc).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/tolerance.h"
#include "storage/run_store.h"

namespace gaugeloop {

class CharacteristicSummer {
 public:
  // One characteristic of run `run_id`: runs oldest first, each run's by position.
  void add(std::int64_t run_id, const Characteristic& c);
  // The summaries of what was added, in the order keys first appeared; `runs` and the times
  // are the window's (a run without characteristics counts).
  CharacteristicSummaries finish(int runs, std::string first_started_utc, std::string last_started_utc);

 private:
  std::map<std::string, std::size_t, std::less<>> index_;
  std::vector<CharacteristicSummary> by_key_;
  std::vector<std::vector<double>> values_;
};

}  // namespace gaugeloop

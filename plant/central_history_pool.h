// Idle connections to the central history, handed to one thread at a time: the HTTP API's
// requests read the plant's runs ([http] history = "central") without each connecting and
// checking the schema again, and without two threads sharing a connection.
#pragma once

#include <string>
#include <utility>

#include "core/idle_pool.h"
#include "core/result.h"
#include "plant/central_history.h"

namespace gaugeloop {

class CentralHistoryPool {
 public:
  using Lease = IdlePool<CentralHistory>::Lease;

  explicit CentralHistoryPool(std::string url) : url_(std::move(url)) {}

  // An idle connection, or a new one (CentralHistory::open's errors: kStorage for a server it
  // cannot reach or a schema it cannot read).
  Result<Lease> acquire() {
    return pool_.acquire([this] { return CentralHistory::open(url_); });
  }

  const std::string& url() const { return url_; }

 private:
  const std::string url_;
  IdlePool<CentralHistory> pool_;
};

}  // namespace gaugeloop

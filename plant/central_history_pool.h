// Idle connections to the central history, handed to one thread at a time: the HTTP API's
// requests read the plant's runs ([http] history = "central") without each connecting and
// checking the schema again, and without two threads sharing a connection.
#pragma once

#include <mutex>
#include <string>
#include <vector>

#include "core/result.h"
#include "plant/central_history.h"

namespace gaugeloop {

class CentralHistoryPool {
 public:
  explicit CentralHistoryPool(std::string url) : url_(std::move(url)) {}

  // A connection for one request, given back when the lease ends unless discard()ed.
  class Lease {
   public:
    Lease(CentralHistoryPool* pool, CentralHistory history) : pool_(pool), history_(std::move(history)) {}
    Lease(Lease&& other) noexcept;
    Lease& operator=(Lease&&) = delete;
    ~Lease();
    CentralHistory& operator*() { return history_; }
    CentralHistory* operator->() { return &history_; }
    // The connection failed (the server went away): close it rather than hand it on.
    void discard() { pool_ = nullptr; }

   private:
    CentralHistoryPool* pool_;
    CentralHistory history_;
  };

  // An idle connection, or a new one (CentralHistory::open's errors: kStorage for a server it
  // cannot reach or a schema it cannot read).
  Result<Lease> acquire();

  const std::string& url() const { return url_; }

 private:
  void give_back(CentralHistory history);

  const std::string url_;
  std::mutex mutex_;
  std::vector<CentralHistory> idle_;
};

}  // namespace gaugeloop

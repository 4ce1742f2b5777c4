// Idle connections (or any object a thread uses alone) handed to one user at a time and given
// back after: requests reuse what they open instead of opening, and checking, again each time.
#pragma once

#include <mutex>
#include <utility>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

template <typename T>
class IdlePool {
 public:
  // One T for one user, given back when the lease ends unless discard()ed.
  class Lease {
   public:
    Lease(IdlePool* pool, T item) : pool_(pool), item_(std::move(item)) {}
    Lease(Lease&& other) noexcept : pool_(std::exchange(other.pool_, nullptr)), item_(std::move(other.item_)) {}
    Lease& operator=(Lease&&) = delete;
    ~Lease() {
      if (pool_ != nullptr) pool_->give_back(std::move(item_));
    }
    T& operator*() { return item_; }
    T* operator->() { return &item_; }
    // It failed (a connection lost): dropped rather than handed to the next user.
    void discard() { pool_ = nullptr; }

   private:
    IdlePool* pool_;
    T item_;
  };

  // An idle T, or the one `open()` (returning Result<T>) makes; open's error otherwise.
  template <typename Open>
  Result<Lease> acquire(const Open& open) {
    {
      std::lock_guard lock(mutex_);
      if (!idle_.empty()) {
        T item = std::move(idle_.back());
        idle_.pop_back();
        return Lease(this, std::move(item));
      }
    }
    Result<T> item = open();
    if (!item) return item.error();
    return Lease(this, std::move(*item));
  }

 private:
  void give_back(T item) {
    std::lock_guard lock(mutex_);
    idle_.push_back(std::move(item));
  }

  std::mutex mutex_;
  std::vector<T> idle_;
};

}  // namespace gaugeloop

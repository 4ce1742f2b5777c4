#include "plant/central_history_pool.h"

#include <utility>

namespace gaugeloop {

CentralHistoryPool::Lease::Lease(Lease&& other) noexcept
    : pool_(std::exchange(other.pool_, nullptr)), history_(std::move(other.history_)) {}

CentralHistoryPool::Lease::~Lease() {
  if (pool_ != nullptr) pool_->give_back(std::move(history_));
}

Result<CentralHistoryPool::Lease> CentralHistoryPool::acquire() {
  {
    std::lock_guard lock(mutex_);
    if (!idle_.empty()) {
      CentralHistory history = std::move(idle_.back());
      idle_.pop_back();
      return Lease(this, std::move(history));
    }
  }
  Result<CentralHistory> history = CentralHistory::open(url_);
  if (!history) return history.error();
  return Lease(this, std::move(*history));
}

void CentralHistoryPool::give_back(CentralHistory history) {
  std::lock_guard lock(mutex_);
  idle_.push_back(std::move(history));
}

}  // namespace gaugeloop

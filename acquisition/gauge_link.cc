// GaugeLink transitions, as drawn in the header.
#include "acquisition/gauge_link.h"

#include <algorithm>

namespace gaugeloop {

std::string_view link_state_name(LinkState state) {
  switch (state) {
    case LinkState::kDisconnected:
      return "disconnected";
    case LinkState::kConnected:
      return "connected";
    case LinkState::kBackingOff:
      return "backing off";
    case LinkState::kFailed:
      return "failed";
  }
  return "?";
}

void GaugeLink::move_to(LinkState next) {
  if (next == state_) return;
  const LinkState from = state_;
  state_ = next;
  if (on_transition_) on_transition_(from, next);
}

bool GaugeLink::spent() {
  const auto now = clock_.now();
  if (failures_++ == 0) outage_since_ = now;
  if (failures_ < policy_.max_attempts) return false;
  return !ever_connected_ || now - outage_since_ >= patience_;
}

Status GaugeLink::give_up(const Error& e, std::string_view where_now) {
  failure_ = e;
  if (!ever_connected_) {
    failure_.message += " (" + std::to_string(failures_) + " attempts)";
  } else {
    failure_.message = "gauge at " + gauge_.address() + " stopped answering " + std::string(where_now) + ": " +
                       e.message + " (gave up after " + std::to_string(failures_) + " attempts); no run was stored";
  }
  move_to(LinkState::kFailed);
  return failure_;
}

Status GaugeLink::ensure(std::string_view where_now) {
  while (true) {
    switch (state_) {
      case LinkState::kFailed:
        return failure_;
      case LinkState::kConnected:
        if (gauge_.connected()) return {};
        move_to(LinkState::kBackingOff);  // the client closed itself after an error
        break;
      case LinkState::kDisconnected:
      case LinkState::kBackingOff: {
        const bool reconnect = state_ == LinkState::kBackingOff;
        if (reconnect) {
          clock_.sleep_for(backoff_);  // backoff between reconnects, not synchronisation
          backoff_ = std::min(backoff_ * 2, policy_.backoff_max);
        }
        Status s = gauge_.connect();
        if (s) {
          if (reconnect && ever_connected_) ++reconnects_;
          ever_connected_ = true;
          move_to(LinkState::kConnected);
          return {};
        }
        if (spent()) return give_up(s.error(), where_now);
        move_to(LinkState::kBackingOff);
        break;
      }
    }
  }
}

Status GaugeLink::failed(const Error& e, std::string_view where_now) {
  if (state_ == LinkState::kFailed) return failure_;
  if (gauge_.connected()) gauge_.disconnect();  // start clean after any error: no late reply survives
  if (spent()) return give_up(e, where_now);
  move_to(LinkState::kBackingOff);
  return {};
}

void GaugeLink::succeeded() {
  failures_ = 0;
  backoff_ = policy_.backoff_initial;
}

}  // namespace gaugeloop

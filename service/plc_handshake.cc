// The PLC handshake's transitions (plc_handshake.h has the table).
#include "service/plc_handshake.h"

#include <algorithm>
#include <utility>

namespace gaugeloop {

std::string_view plc_state_name(PlcState state) {
  switch (state) {
    case PlcState::kIdle:
      return "idle";
    case PlcState::kBusy:
      return "busy";
    case PlcState::kDone:
      return "done";
  }
  return "?";
}

std::string_view plc_event_name(PlcEvent event) {
  switch (event) {
    case PlcEvent::kConnected:
      return "connected";
    case PlcEvent::kConnectFailed:
      return "connect failed";
    case PlcEvent::kLinkLost:
      return "link lost";
    case PlcEvent::kRequestAccepted:
      return "request accepted";
    case PlcEvent::kRequestRefused:
      return "request refused";
    case PlcEvent::kCycleEnded:
      return "cycle ended";
    case PlcEvent::kOutcomeWritten:
      return "outcome written";
    case PlcEvent::kCleared:
      return "cleared";
    case PlcEvent::kClearedEarly:
      return "cleared early";
  }
  return "?";
}

PlcHandshake::PlcHandshake(PlcRegisters& plc, PlcCycleRunner& runner, PlcHandshakeSettings settings, Clock& clock)
    : plc_(plc), runner_(runner), settings_(settings), clock_(clock) {}

void PlcHandshake::link_failed(const Error& e, std::vector<PlcEvent>& events) {
  plc_.disconnect();
  last_link_error_ = e.message;
  backoff_ = settings_.reconnect_min;
  next_connect_ = clock_.now() + backoff_;
  events.push_back(PlcEvent::kLinkLost);
}

std::vector<PlcEvent> PlcHandshake::step() {
  std::vector<PlcEvent> events;
  // The cycle ends whether or not the PLC can be told: its outcome waits for the link.
  if (state_ == PlcState::kBusy) {
    if (std::optional<PlcCycleOutcome> o = runner_.poll()) {
      outcome_ = std::move(*o);
      state_ = PlcState::kDone;
      delivered_ = false;
      events.push_back(PlcEvent::kCycleEnded);
    }
  }

  if (!plc_.connected()) {
    const auto t = clock_.now();
    if (t < next_connect_) return events;
    if (Status s = plc_.connect(); !s) {
      backoff_ = backoff_.count() == 0 ? settings_.reconnect_min : std::min(backoff_ * 2, settings_.reconnect_max);
      next_connect_ = t + backoff_;
      last_link_error_ = s.error().message;
      events.push_back(PlcEvent::kConnectFailed);
      return events;
    }
    backoff_ = std::chrono::milliseconds{0};
    events.push_back(PlcEvent::kConnected);
  }

  Result<PlcRequestWords> req = plc_.read_request();
  if (!req) {
    link_failed(req.error(), events);
    return events;
  }
  const bool measure = req->measure();
  switch (state_) {
    case PlcState::kIdle:
      if (!measure) {
        armed_ = true;
      } else if (armed_) {
        armed_ = false;
        cleared_early_ = false;
        request_ = *req;
        if (std::optional<PlcCycleOutcome> at_once = runner_.start(*req)) {
          outcome_ = std::move(*at_once);
          state_ = PlcState::kDone;
          delivered_ = false;
          events.push_back(PlcEvent::kRequestRefused);
        } else {
          outcome_.reset();
          state_ = PlcState::kBusy;
          events.push_back(PlcEvent::kRequestAccepted);
        }
      }
      break;
    case PlcState::kBusy:
      if (!measure && !cleared_early_) {
        cleared_early_ = true;
        events.push_back(PlcEvent::kClearedEarly);
      }
      break;
    case PlcState::kDone:
      // Cleared only once the outcome was written: done or fault stands for one poll at least.
      if (!measure && delivered_) {
        state_ = PlcState::kIdle;
        armed_ = true;
        events.push_back(PlcEvent::kCleared);
      }
      break;
  }

  ++words_.heartbeat;
  words_.ack = state_ != PlcState::kIdle;
  words_.busy = state_ == PlcState::kBusy;
  const bool ended = state_ == PlcState::kDone && outcome_.has_value();
  words_.done = ended && plc_result_is_done(outcome_->code);
  words_.fault = ended && !plc_result_is_done(outcome_->code);
  if (state_ == PlcState::kBusy) {
    words_.result_code = PlcResultCode::kTablePushed;
    words_.run_id = 0;
    words_.table_version = 0;
  } else if (outcome_) {  // kept in kIdle until the next request, for a PLC that looks late
    words_.result_code = outcome_->code;
    words_.run_id = outcome_->run_id;
    words_.table_version = outcome_->table_version;
  }
  if (Status s = plc_.write_service_words(words_); !s) {
    link_failed(s.error(), events);
    return events;
  }
  if (state_ == PlcState::kDone && !delivered_) {
    delivered_ = true;
    events.push_back(PlcEvent::kOutcomeWritten);
  }
  return events;
}

}  // namespace gaugeloop

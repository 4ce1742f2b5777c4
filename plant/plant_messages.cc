// The plant's broker messages: topic tree and payloads (docs/plant.md).
#include "plant/plant_messages.h"

#include <algorithm>
#include <utility>

#include "core/utc_time.h"
#include "report/run_json.h"

namespace gaugeloop {

using nlohmann::json;

namespace {

// Text a person typed (a note) may hold bytes that are not UTF-8: replaced (U+FFFD) rather
// than thrown on, so one odd run never stops the messages behind it.
std::string dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

}  // namespace

Status check_topic_level(std::string_view key, std::string_view value) {
  const std::string advice =
      "; give a name without '/', '+', '#' (it is one level of the topic gaugeloop/<site>/<machine>/...)";
  if (value.empty()) {
    return make_error(ErrorCode::kInvalidInput, std::string(key) + " is empty" + advice);
  }
  if (value.size() > 64) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string(key) + " \"" + std::string(value) + "\" is longer than 64 characters" + advice);
  }
  for (char c : value) {
    if (c == '/' || c == '+' || c == '#' || c == '\0') {
      const std::string shown = c == '\0' ? std::string("NUL") : std::string("'") + c + "'";
      return make_error(ErrorCode::kInvalidInput, std::string(key) + " \"" + std::string(value) + "\" holds " + shown +
                                                      ", which MQTT reads as a topic separator or wildcard" + advice);
    }
  }
  return {};
}

std::string plant_topic(const std::string& site, const std::string& machine, std::string_view kind) {
  return "gaugeloop/" + site + "/" + machine + "/" + std::string(kind);
}

std::string state_payload(const std::string& machine, std::string_view state, const std::string& detail) {
  json j{{"state", state}, {"machine", machine}, {"at_utc", utc_now()}};
  j["detail"] = detail.empty() ? json(nullptr) : json(detail);
  return dump(j);
}

namespace {

// The stored JSON of a verdict or state row, which the database wrote (json_object) or the
// service did: an object, or the row is refused rather than sent malformed.
Result<json> stored_object(const OutboxMessage& m) {
  json j = json::parse(m.payload, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) {
    return make_error(ErrorCode::kInvalidInput, "outbox message " + std::to_string(m.id) + " (" + m.topic +
                                                    "): its stored payload is not a JSON object: " + m.payload);
  }
  return j;
}

// The run a row names; empty when it is gone.
Result<std::optional<StoredRun>> run_of(const RunStore& store, std::int64_t run_id) {
  Result<StoredRun> run = store.load_run(run_id);
  if (run) return std::optional<StoredRun>(std::move(*run));
  if (run.error().code == ErrorCode::kNotFound) return std::optional<StoredRun>();
  return run.error();
}

}  // namespace

Result<std::optional<PlantMessage>> render_message(const RunStore& store, const OutboxMessage& m,
                                                   const std::string& site, const std::string& machine) {
  PlantMessage out;
  out.topic = plant_topic(site, machine, m.topic);
  if (m.topic == "state") {
    Result<json> j = stored_object(m);
    if (!j) return j.error();
    out.payload = dump(*j);
    return std::optional<PlantMessage>(std::move(out));
  }
  if (m.topic != "run" && m.topic != "nc" && m.topic != "verdict") {
    return make_error(ErrorCode::kInvalidInput, "outbox message " + std::to_string(m.id) + " has the unknown topic \"" +
                                                    m.topic + "\"; this gaugeloop sends run, nc, verdict and state");
  }
  if (m.topic == "nc" && m.run_id == 0) {
    // A program written from the drawing (nc new): the push alone, this machine's, no run.
    Result<std::optional<NcPush>> push = store.push_by_id(m.push_id);
    if (!push) return push.error();
    if (!push->has_value()) return std::optional<PlantMessage>();
    json j = nc_push_json(**push);
    j["machine"] = machine;
    j["run_uuid"] = nullptr;
    j["message_uuid"] = m.uuid;
    out.payload = dump(j);
    return std::optional<PlantMessage>(std::move(out));
  }
  Result<std::optional<StoredRun>> run = run_of(store, m.run_id);
  if (!run) return run.error();
  if (!run->has_value()) return std::optional<PlantMessage>();
  const StoredRun& r = **run;
  json j;
  if (m.topic == "run") {
    j = run_detail_json(r);
  } else if (m.topic == "verdict") {
    Result<json> stored = stored_object(m);
    if (!stored) return stored.error();
    j = std::move(*stored);
    j["run_uuid"] = r.summary.uuid;
  } else {
    const auto push =
        std::find_if(r.pushes.begin(), r.pushes.end(), [&m](const NcPush& p) { return p.id == m.push_id; });
    if (push == r.pushes.end()) return std::optional<PlantMessage>();
    j = nc_push_json(*push);
    j["machine"] = r.summary.machine;
    j["run_uuid"] = r.summary.uuid;
  }
  j["message_uuid"] = m.uuid;
  out.payload = dump(j);
  return std::optional<PlantMessage>(std::move(out));
}

}  // namespace gaugeloop

// The plant's broker messages: the topic tree and the payloads (docs/plant.md, "Messages to
// the broker"). Every payload is the JSON the command line prints with --json, plus the
// message's identity ("message_uuid"), by which a consumer drops a second delivery.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

// Checks that `value`, given as `key` (e.g. "[plant.mqtt] site"), can be one level of an MQTT
// topic: not empty, no '/', '+', '#' or NUL, at most 64 bytes. kInvalidInput naming the key.
Status check_topic_level(std::string_view key, std::string_view value);

// "gaugeloop/<site>/<machine>/<kind>", kind one of run, nc, verdict, state.
std::string plant_topic(const std::string& site, const std::string& machine, std::string_view kind);

// One outbox row made ready to publish.
struct PlantMessage {
  std::string topic;    // the whole topic
  std::string payload;  // JSON text
  // Outbox rows are never retained: an old row sent after an outage must not stand as the
  // grinder's state. The retained state is the connection's (online, offline, the last will),
  // published by the sender itself.
  bool retain = false;
};

// The payload of a service state message, as the service queues it (enqueue_state):
// {"state": "...", "machine": ..., "at_utc": ..., "detail": ...}.
std::string state_payload(const std::string& machine, std::string_view state, const std::string& detail = {});

// Renders one outbox row from the database `store` (the run or the push it names) for
// `machine` under `site`:
//  - run: run_detail_json of the run (the keys of `gaugeloop runs show --json`) + message_uuid
//  - nc: nc_push_json of the push + machine, run_uuid, message_uuid
//  - verdict: the stored payload + run_uuid, message_uuid
//  - state: the stored payload as is (a state change, with its time).
// Empty when the record it names is gone (a run or push deleted by hand): the caller skips
// the row. kStorage when the database refuses; kInvalidInput for an unknown topic or a
// stored payload that is not a JSON object.
Result<std::optional<PlantMessage>> render_message(const RunStore& store, const OutboxMessage& m,
                                                   const std::string& site, const std::string& machine);

}  // namespace gaugeloop

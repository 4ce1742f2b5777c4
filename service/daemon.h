// The service's life cycle as a process: read and check the configuration, check the database
// and finish interrupted pushes, start the PLC trigger and the HTTP API, then wait for signals:
// SIGHUP reloads the configuration (and the HTTP token), SIGTERM or SIGINT let the run in
// progress finish, answer the PLC, and stop. Under systemd it says when it is ready, reloading
// and stopping, and feeds the watchdog while the PLC trigger and the HTTP API are alive
// (service/systemd_notify.h). docs/service.md.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "config/service_config.h"
#include "core/result.h"

namespace gaugeloop {

// "<file>: machine grinder-1, parts intake_flat lobe 1, database ..., PLC ...": what a
// configuration sets up, for the log and `serve --check`.
std::string describe_service_config(const ServiceConfig& config);

// The outbox of the run database `db_path` queues broker messages exactly while a broker is
// configured: on, with its bound, for [plant.mqtt]; off without it (a file a service with a
// broker used before would otherwise go on queuing messages nobody sends; those already
// queued stay). A database that has never had it on is not written. Errors name the database
// and say the service did not start.
Status configure_plant_outbox(const std::filesystem::path& db_path, const std::optional<MqttSettings>& mqtt);

// Runs the service until SIGTERM or SIGINT; returns ok after a clean stop. Blocks SIGTERM,
// SIGINT and SIGHUP in the calling thread first (call it before any other thread starts, so
// that only it receives them). Errors: the configuration refused (its own code), the database
// refused (kInvalidInput: nothing started), interrupted pushes that cannot be reconciled, the
// HTTP API not bound. Each message says what was refused and that the service did not start.
Status run_service(const std::filesystem::path& config_path);

}  // namespace gaugeloop

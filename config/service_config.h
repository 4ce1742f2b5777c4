// The service's one configuration file (TOML): gauge link and register map, parts, analysis,
// compensation, NC output, database and HTTP. Documented key by key in docs/service.md, with
// a commented example in examples/service/gaugeloop.toml.
#pragma once

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "acquisition/modbus_gauge.h"
#include "acquisition/plc_link.h"
#include "config/part_file.h"
#include "core/lift_table.h"
#include "core/result.h"
#include "job/measure_job.h"
#include "plant/central_sync.h"
#include "plant/mqtt_settings.h"
#include "report/shaft.h"

namespace gaugeloop {

// A part the service may be asked to measure, with its design already read.
struct ServicePart {
  PartFile file;
  LiftTable design;
  // The number the PLC names this part by (with the part file's lobe); absent: the PLC
  // cannot ask for it. One number is one part name; (number, lobe) is unique.
  std::optional<int> plc_part_number;
};

// The HTTP API's address and token ([http]; served by service/http_api.h).
struct HttpSettings {
  std::string host = "127.0.0.1";  // bound to loopback unless configured
  int port = 8080;                 // 0: a free port (tests); read it back with HttpApi::port()
  // Empty: the API is read-only, and every write is refused with 403. Otherwise a write needs
  // the header `Authorization: Bearer <token>` (401 without it or with another token).
  std::string token;
  // Both set: HTTPS with this certificate chain and private key (PEM files); both empty: plain
  // HTTP. The config reader checks they can be read.
  std::filesystem::path tls_cert;
  std::filesystem::path tls_key;
  // [http] history = "central": the central history (the [plant.central] URL) that the run lists
  // and trends of the API and pages read, every grinder's runs; empty ("local", the default):
  // the service's own file. A run's own page always reads the file.
  std::string history_url;
};

// The PLC trigger: the PLC's Modbus server and the handshake block on it (docs/service.md).
struct PlcSettings {
  PlcLinkSettings link;
  std::chrono::milliseconds poll_interval{100};  // one read and one write per interval
};

struct ServiceConfig {
  std::filesystem::path source;  // the file it was read from
  std::string machine = "grinder-1";
  ModbusSettings gauge;
  std::vector<ServicePart> parts;  // distinct (name, lobe); at least one
  // Everything a job needs except the part: poller, analysis, compensation, NC output,
  // database (JobSettings' part, design and nc_program are filled per part by job_for).
  JobSettings job;
  // [database] integrity_check_hours: how often the service checks the run database whole on
  // a thread of its own (service/integrity_watch.h), and at once after a stop that was not clean.
  int integrity_check_hours = 24;
  // For the parts with a speed program (their part file's [speed]): [nc] main_speed_template,
  // the main program that calls the speed subprogram, used instead of [nc] main_template;
  // the speed subprogram's template, [nc] speed_template, is job.nc_speed_template.
  std::string nc_main_speed_template;
  std::string nc_main_speed_template_name;
  // For crankpins (part files with [pin], docs/crankpins.md): [nc] pin_main_template couples X
  // to C (C-X), [nc] pin_main_xy_template couples X and Y (C-X-Y); used instead of [nc]
  // main_template, and empty: no main program for those pins. The Y table's template, [nc]
  // y_template, is job.nc_y_template; its numbers [nc] y_table_numbers (default [3, 4]) and the
  // Y slide's limits [nc] y_min_mm... are in job.
  // [nc] pin_command_error_um: the command position error a pin's tables keep (default
  // kPinCommandErrorBoundUm, 0.1 um; [nc] command_error_um is the lobes').
  double pin_command_error_um = kPinCommandErrorBoundUm;
  std::string nc_pin_main_template;
  std::string nc_pin_main_template_name;
  std::string nc_pin_main_xy_template;
  std::string nc_pin_main_xy_template_name;
  // For lobes with a correction layer (their part file's [correction_layer], docs/nc_output.md):
  // [nc] layer_main_template couples X to the design table from C and to the layer from SIM1,
  // used instead of [nc] main_template (which such a part's job refuses).
  std::string nc_layer_main_template;
  std::string nc_layer_main_template_name;
  std::optional<HttpSettings> http;  // absent: no HTTP API
  std::optional<PlcSettings> plc;    // absent: no PLC trigger
  // [plant.mqtt]: the plant's broker the outbox sender delivers runs, pushes and states to
  // (docs/plant.md); absent: no broker, the outbox stays disabled.
  std::optional<MqttSettings> mqtt;
  // [plant.central]: the central history the service syncs its runs, pushes and events into
  // (docs/plant.md); absent: the service does not sync (`gaugeloop plant sync` may).
  std::optional<CentralSyncSettings> central;
  // [[shaft]] file = "...": the camshafts whose lobes the service measures, for the camshaft
  // record of a serial on the pages (/api/shaft); none: the pages list a serial's lobes
  // without index errors.
  std::vector<ShaftLayout> shafts;
};

// Reads and checks the whole file before anything uses it: every part file and lift table
// is read, every design is made into a curve table within the axis limits, the NC template
// renders. Paths in the file are relative to its directory. Errors (kInvalidInput, or
// kNotFound for a missing file) name the file, the line and the key, and say what is allowed;
// unknown keys are refused so a typo never falls back to a default silently.
Result<ServiceConfig> read_service_config(const std::filesystem::path& path);

// Where the service keeps its runs and writes its NC programs.
struct ServiceDataPaths {
  std::filesystem::path db_path;  // [database] path
  std::filesystem::path nc_dir;   // [nc] dir
  std::string machine;            // machine: the grinder's name (plant sync names its copy by it)
};

// Only [database] path and [nc] dir of the service's config, relative to its directory as the
// service reads them, with their defaults: for the query commands' --config. Nothing else in
// the file is read or checked, so it works for a user who may read the runs but could not
// start the service (the token file and a writable database are the service's business).
// Errors (kNotFound, kInvalidInput) name the file, the line and the key.
Result<ServiceDataPaths> read_service_data_paths(const std::filesystem::path& path);

// The part (name and lobe) among the configured ones; kNotFound listing them.
Result<const ServicePart*> find_part(const ServiceConfig& config, const std::string& name, int lobe);

// "intake_flat lobe 1, exhaust_roller lobe 2": the parts a config has, for messages.
std::string configured_parts(const ServiceConfig& config);

// The part the PLC names by `plc_part_number` and `lobe`; kNotFound listing the numbered ones.
Result<const ServicePart*> find_plc_part(const ServiceConfig& config, int plc_part_number, int lobe);

// The job settings for measuring `part` under `config`: with the part's speed program (its
// [speed]) the main program is [nc] main_speed_template, when set; for a pin, its [pin] and
// the pin main program of its mode.
JobSettings job_for(const ServiceConfig& config, const ServicePart& part);

}  // namespace gaugeloop

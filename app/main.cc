// The gaugeloop command line: demo, sim, measure and runs.
#include <signal.h>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "acquisition/modbus_gauge.h"
#include "app/embedded_defaults.h"
#include "app/measure_job.h"
#include "app/part_file.h"
#include "simulator/gauge_simulator.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

// Exit codes, documented in README.md.
enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,
  kExitBadInput = 2,
  kExitGauge = 3,
  kExitStorage = 4,
  kExitNcOutput = 5,
};

int exit_code_for(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidInput:
    case ErrorCode::kNotFound:
    case ErrorCode::kRefused:
      return kExitBadInput;
    case ErrorCode::kGaugeUnreachable:
    case ErrorCode::kGaugeTimeout:
    case ErrorCode::kGaugeProtocol:
    case ErrorCode::kIncompleteRun:
      return kExitGauge;
    case ErrorCode::kStorage:
      return kExitStorage;
    case ErrorCode::kIo:
      return kExitNcOutput;
    case ErrorCode::kInternal:
      return kExitInternal;
  }
  return kExitInternal;
}

int report_error(const Error& e) {
  spdlog::error("{}", e.message);
  return exit_code_for(e.code);
}

// Where a run's files go unless flags say otherwise.
struct DataPaths {
  std::string data_dir = "gaugeloop-data";
  std::string nc_dir;  // empty: <data_dir>/nc
  std::filesystem::path db() const { return std::filesystem::path(data_dir) / "gaugeloop.sqlite"; }
  std::filesystem::path nc() const {
    return nc_dir.empty() ? std::filesystem::path(data_dir) / "nc" : std::filesystem::path(nc_dir);
  }
};

void add_data_dir_option(CLI::App& cmd, DataPaths& paths) {
  cmd.add_option("--data-dir", paths.data_dir, "Directory holding the run database gaugeloop.sqlite")
      ->capture_default_str();
}

// A part and its design table, from a file or from the embedded sample.
struct LoadedPart {
  PartFile file;
  LiftTable design;
};

Result<LoadedPart> load_part(const std::string& part_path) {
  Result<PartFile> pf = part_path.empty() ? parse_part_toml(embedded::kDemoPartToml, "embedded:intake_flat.toml", "")
                                          : read_part_file(part_path);
  if (!pf) return pf.error();
  Result<LiftTable> design = part_path.empty()
                                 ? parse_lift_table_csv(embedded::kDemoLiftCsv, "embedded:intake_flat.csv")
                                 : read_lift_table_csv(pf->part.lift_table);
  if (!design) return design.error();
  return LoadedPart{std::move(*pf), std::move(*design)};
}

Result<std::string> load_template(const std::string& path, std::string& name) {
  if (path.empty()) {
    name = "embedded:cam_table.spf";
    return std::string(embedded::kNcTemplate);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "NC template " + path + ": cannot be opened; check --template");
  std::ostringstream buf;
  buf << in.rdbuf();
  name = path;
  return buf.str();
}

void print_report(const JobReport& r, const Part& part, const std::string& machine) {
  const auto& a = r.analysis;
  const int revs = static_cast<int>(r.measured.revolutions.size());
  std::printf("run %lld: %s lobe %d on %s\n", static_cast<long long>(r.run_id), part.name.c_str(), part.lobe,
              machine.c_str());
  std::printf("  revolutions       %d (%lld discarded, %lld reconnects, %lld polls)\n", revs,
              static_cast<long long>(r.measured.discarded_revolutions), static_cast<long long>(r.measured.reconnects),
              static_cast<long long>(r.measured.polls));
  std::printf("  degrees captured  %d of %d\n", revs * kDegreesPerRevolution, revs * kDegreesPerRevolution);
  std::printf("  max lift error    %.2f um\n", a.max_abs_error_um);
  std::printf("  RMS lift error    %.2f um\n", a.rms_error_um);
  std::printf("  peak to valley    %.2f um\n", a.peak_to_valley_um);
  std::printf("  repeatability     %.2f um (largest per-degree standard deviation)\n", a.repeatability_um);
  if (r.correction_in_force_run) {
    std::printf("  correction        %.2f um max, built on run %lld's (the table in force)\n", r.correction_max_um,
                static_cast<long long>(*r.correction_in_force_run));
  } else {
    std::printf("  correction        %.2f um max, from the design\n", r.correction_max_um);
  }
  std::printf("  NC file           %s (%d points)\n", r.nc_file.string().c_str(), r.table_points);
  std::printf("  database          %s\n", r.db_path.string().c_str());
}

struct MeasureOptions {
  DataPaths paths;
  std::string part_path;
  std::string template_path;
  int revolutions = 3;
  double table_step_deg = 1.0;
  std::string machine = "grinder-1";
  std::string note;
  int response_timeout_ms = 200;
  std::string mode = "latched";  // latched | live
};

void add_measure_options(CLI::App& cmd, MeasureOptions& o) {
  add_data_dir_option(cmd, o.paths);
  cmd.add_option("--nc-dir", o.paths.nc_dir, "Directory the curve-table program is written to [<data-dir>/nc]");
  cmd.add_option("--template", o.template_path, "NC template with {{placeholders}} [built-in Sinumerik 840D table]");
  cmd.add_option("--revolutions", o.revolutions, "Complete revolutions to average (at least 3)")
      ->capture_default_str()
      ->check(CLI::Range(3, 100));
  cmd.add_option("--table-step-deg", o.table_step_deg, "C step of the curve table in degrees")->capture_default_str();
  cmd.add_option("--machine", o.machine, "Machine name stored with the run")->capture_default_str();
  cmd.add_option("--note", o.note, "Operator note stored with the run");
  cmd.add_option("--response-timeout-ms", o.response_timeout_ms, "Gauge response timeout")
      ->capture_default_str()
      ->check(CLI::Range(10, 10000));
  cmd.add_option("--mode", o.mode,
                 "latched: drain the amplifier's per-degree latch buffer; live: poll the reading and interpolate "
                 "(amplifiers without a latch input, slow spindles)")
      ->check(CLI::IsMember({"latched", "live"}))
      ->capture_default_str();
}

int run_job(GaugeClient& gauge, const LoadedPart& lp, const MeasureOptions& o, bool build_on_table_in_force) {
  std::string template_name;
  Result<std::string> tmpl = load_template(o.template_path, template_name);
  if (!tmpl) return report_error(tmpl.error());
  JobSettings js;
  js.part = lp.file.part;
  js.design = lp.design;
  js.nc_program = lp.file.nc_program;
  js.poller.revolutions = o.revolutions;
  js.poller.mode = o.mode == "live" ? SamplingMode::kLive : SamplingMode::kLatched;
  js.db_path = o.paths.db();
  js.nc_dir = o.paths.nc();
  js.nc_template = std::move(*tmpl);
  js.nc_template_name = template_name;
  js.table_step_deg = o.table_step_deg;
  js.machine = o.machine;
  js.note = o.note;
  js.build_on_table_in_force = build_on_table_in_force;
  Result<JobReport> report = run_measure_job(gauge, js);
  if (!report) return report_error(report.error());
  print_report(*report, js.part, js.machine);
  return kExitOk;
}

int cmd_demo(const MeasureOptions& o, const SimulatorSettings& sim_settings) {
  Result<LoadedPart> lp = load_part(o.part_path);
  if (!lp) return report_error(lp.error());
  auto sim = GaugeSimulator::start(lp->file.part, lp->design, sim_settings);
  if (!sim) return report_error(sim.error());
  std::printf(
      "simulator: %s lobe %d turning at %.0f rpm on 127.0.0.1:%d (form error %.1f um peak, noise %.1f um RMS)\n",
      lp->file.part.name.c_str(), lp->file.part.lobe, sim_settings.speed_rpm, (*sim)->port(),
      sim_settings.lobe_error_peak_um, sim_settings.noise_rms_um);
  std::printf("measuring %d revolutions in %s mode...\n", o.revolutions, o.mode.c_str());
  std::fflush(stdout);
  ModbusTcpSettings ms;
  ms.port = (*sim)->port();
  ms.response_timeout = std::chrono::milliseconds(o.response_timeout_ms);
  ModbusTcpGauge gauge(ms);
  return run_job(gauge, *lp, o, /*build_on_table_in_force=*/false);
}

int cmd_measure(const MeasureOptions& o, const std::string& gauge_address) {
  const auto colon = gauge_address.rfind(':');
  ModbusTcpSettings ms;
  try {
    if (colon == std::string::npos) throw std::invalid_argument("no port");
    ms.host = gauge_address.substr(0, colon);
    size_t used = 0;
    ms.port = std::stoi(gauge_address.substr(colon + 1), &used);
    if (used != gauge_address.size() - colon - 1 || ms.port <= 0 || ms.port > 65535)
      throw std::invalid_argument("port");
  } catch (const std::exception&) {
    return report_error(make_error(ErrorCode::kInvalidInput,
                                   "--gauge `" + gauge_address + "`: expected HOST:PORT, e.g. 192.168.0.20:502"));
  }
  ms.response_timeout = std::chrono::milliseconds(o.response_timeout_ms);
  Result<LoadedPart> lp = load_part(o.part_path);
  if (!lp) return report_error(lp.error());
  ModbusTcpGauge gauge(ms);
  return run_job(gauge, *lp, o, /*build_on_table_in_force=*/true);
}

int cmd_sim(const std::string& part_path, const SimulatorSettings& settings) {
  Result<LoadedPart> lp = load_part(part_path);
  if (!lp) return report_error(lp.error());
  // Block the stop signals before the server thread starts, so only sigwait below sees them.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  auto sim = GaugeSimulator::start(lp->file.part, lp->design, settings);
  if (!sim) return report_error(sim.error());
  std::printf("gaugeloop sim: %s lobe %d at %.0f rpm, Modbus TCP on %s:%d (input registers 0-8, docs/simulator.md)\n",
              lp->file.part.name.c_str(), lp->file.part.lobe, settings.speed_rpm, settings.host.c_str(),
              (*sim)->port());
  std::printf("port %d\n", (*sim)->port());
  std::fflush(stdout);
  int sig = 0;
  sigwait(&stop_signals, &sig);
  (*sim)->stop();
  spdlog::info("simulator stopped after {} requests", (*sim)->requests_served());
  return kExitOk;
}

int cmd_runs_list(const DataPaths& paths, const RunQuery& query, bool json) {
  if (!std::filesystem::exists(paths.db())) {
    return report_error(make_error(ErrorCode::kNotFound,
                                   "no run database at " + paths.db().string() +
                                       "; run `gaugeloop demo` or `gaugeloop measure` first, or give --data-dir"));
  }
  Result<RunStore> store = RunStore::open(paths.db());
  if (!store) return report_error(store.error());
  Result<std::vector<RunSummary>> runs = store->list_runs(query);
  if (!runs) return report_error(runs.error());
  if (json) {
    nlohmann::json out = nlohmann::json::array();
    for (const RunSummary& r : *runs) {
      out.push_back({{"id", r.id},
                     {"started_utc", r.started_utc},
                     {"machine", r.machine},
                     {"part", r.part},
                     {"lobe", r.lobe},
                     {"status", r.status},
                     {"revolutions", r.revolutions},
                     {"degrees_captured", r.degrees_captured},
                     {"max_abs_error_um", r.max_abs_error_um},
                     {"rms_error_um", r.rms_error_um},
                     {"repeatability_um", r.repeatability_um},
                     {"nc_file", r.nc_file}});
    }
    std::cout << out.dump(2) << "\n";
    return kExitOk;
  }
  std::printf("%6s  %-20s  %-10s  %-24s %4s  %4s  %8s  %8s  %8s  %s\n", "run", "started (UTC)", "machine", "part",
              "lobe", "revs", "max um", "rms um", "rep um", "status");
  for (const RunSummary& r : *runs) {
    std::printf("%6lld  %-20s  %-10s  %-24s %4d  %4d  %8.2f  %8.2f  %8.2f  %s\n", static_cast<long long>(r.id),
                r.started_utc.c_str(), r.machine.c_str(), r.part.c_str(), r.lobe, r.revolutions, r.max_abs_error_um,
                r.rms_error_um, r.repeatability_um, r.status.c_str());
  }
  if (runs->empty()) std::printf("(no runs)\n");
  return kExitOk;
}

void add_simulator_options(CLI::App& cmd, SimulatorSettings& s) {
  cmd.add_option("--speed-rpm", s.speed_rpm, "Work spindle speed")->capture_default_str();
  cmd.add_option("--lobe-error-um", s.lobe_error_peak_um, "Peak of the repeatable form error of the simulated lobe")
      ->capture_default_str();
  cmd.add_option("--noise-um", s.noise_rms_um, "Gauge noise, RMS")->capture_default_str();
  cmd.add_option("--seed", s.seed, "Seed of the gauge noise, for a repeatable run [from the clock]");
}

// A fresh noise seed per start unless --seed gave one: real gauge noise does not repeat.
void seed_from_clock_unless_given(const CLI::App& cmd, SimulatorSettings& s) {
  if (cmd.count("--seed") == 0) {
    s.seed = static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count()) | 1u;
  }
}

}  // namespace
}  // namespace gaugeloop

int main(int argc, char** argv) {
  using namespace gaugeloop;
  spdlog::set_default_logger(spdlog::stderr_color_mt("gaugeloop"));
  spdlog::set_pattern("%^%l%$: %v");

  CLI::App app{
      "gaugeloop: measures cam lobes with an in-process gauge over Modbus, compensates the wheel path\n"
      "and writes the Sinumerik 840D curve table. Every run is kept in a SQLite database."};
  app.set_version_flag("--version", GAUGELOOP_VERSION);
  app.require_subcommand(1);

  MeasureOptions demo_opts;
  SimulatorSettings demo_sim;
  CLI::App* demo = app.add_subcommand(
      "demo",
      "Start the built-in gauge simulator on a free loopback port, measure the sample intake lobe through it, "
      "store the run and write the corrected curve table. Needs no files.");
  add_measure_options(*demo, demo_opts);
  demo->add_option("--part", demo_opts.part_path, "Part file to simulate and measure [built-in intake_flat]");
  add_simulator_options(*demo, demo_sim);

  SimulatorSettings sim_settings;
  std::string sim_part;
  CLI::App* sim = app.add_subcommand(
      "sim", "Run the gauge simulator alone as a Modbus TCP server, so any Modbus tool can read it. Stops on Ctrl-C.");
  sim->add_option("--host", sim_settings.host, "Address to listen on")->capture_default_str();
  sim_settings.port = 1502;
  sim->add_option("--port", sim_settings.port, "TCP port; 0 picks a free one")->capture_default_str();
  sim->add_option("--part", sim_part, "Part file to simulate [built-in intake_flat]");
  add_simulator_options(*sim, sim_settings);
  sim->add_option("--time-scale", sim_settings.time_scale, "Simulated seconds per real second")->capture_default_str();
  sim->add_option("--silent-after-revs", sim_settings.silent_after_revolutions,
                  "Fault: stop answering this many revolutions after the first request (-1: never)")
      ->capture_default_str();

  MeasureOptions measure_opts;
  std::string gauge_address;
  CLI::App* measure = app.add_subcommand(
      "measure",
      "Measure one run against a gauge amplifier at HOST:PORT, store it and write the corrected curve table.");
  measure->add_option("--gauge", gauge_address, "Gauge amplifier, HOST:PORT (Modbus TCP)")->required();
  measure->add_option("--part", measure_opts.part_path, "Part file (TOML), see examples/")->required();
  add_measure_options(*measure, measure_opts);

  CLI::App* runs = app.add_subcommand("runs", "Query the run history.");
  runs->require_subcommand(1);
  DataPaths list_paths;
  RunQuery list_query;
  bool list_json = false;
  CLI::App* runs_list = runs->add_subcommand("list", "List runs, newest first.");
  add_data_dir_option(*runs_list, list_paths);
  runs_list->add_option("--limit", list_query.limit, "Most runs to show")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  runs_list->add_option("--part", list_query.part, "Only runs of this part");
  runs_list->add_flag("--json", list_json, "Print JSON instead of a table");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; a bad command line is bad input, exit 2 (README).
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }

  try {
    if (*demo) {
      seed_from_clock_unless_given(*demo, demo_sim);
      return cmd_demo(demo_opts, demo_sim);
    }
    if (*sim) {
      seed_from_clock_unless_given(*sim, sim_settings);
      return cmd_sim(sim_part, sim_settings);
    }
    if (*measure) return cmd_measure(measure_opts, gauge_address);
    if (*runs_list) return cmd_runs_list(list_paths, list_query, list_json);
  } catch (const std::exception& e) {
    // The one boundary for programmer errors and library exceptions on the main thread.
    spdlog::critical("internal error: {}; please report it with the command line used", e.what());
    return kExitInternal;
  }
  return kExitInternal;
}

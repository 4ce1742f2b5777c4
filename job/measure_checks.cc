// The measure job's checks before the gauge is read: names, the design's tables and every
// program they make, the NC directory and the database with room for a run, and a push left
// half done by an earlier run reconciled.
#include "job/measure_checks.h"

#include <stdlib.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>
#include <vector>

#include "compensation/judgement.h"
#include "compensation/pin_kinematics.h"
#include "compensation/pin_path.h"
#include "core/atomic_file.h"
#include "core/number_text.h"
#include "job/layer_files.h"
#include "job/nc_push.h"
#include "job/pin_files.h"
#include "job/program_set.h"
#include "job/speed_files.h"
#include "nc_out/main_program.h"
#include "nc_out/table_guards.h"
#include "nc_out/table_program.h"
#include "report/run_json.h"

namespace gaugeloop {
namespace {

// A part with [speed] needs the speed subprogram's template.
Status check_speed_template(const JobSettings& s) {
  if (!s.speed || !s.nc_speed_template.empty()) return {};
  return make_error(ErrorCode::kInvalidInput,
                    "part " + s.part.name +
                        " has a [speed] section, but no speed subprogram template is set: "
                        "give one (examples/sinumerik/cam_speed.spf, [nc] speed_template) or remove [speed]");
}

// Every program the design's tables make renders, before measuring: the speed subprogram,
// and for versions 1 and 2 (both table numbers, so a template naming a fixed one is refused
// now) the table program, a pin's Y table, and the main program, which must call the speed
// subprogram when there is one.
// A correction layer's main program is rendered with `design_program`, the design table's
// program as `nc new` writes it.
Status check_programs_render(const JobSettings& s, const BuiltTable& design_table,
                             const std::string* design_program = nullptr) {
  std::optional<std::string> speed_program;
  if (design_table.speed) {
    Result<std::string> text = render_speed(s, *design_table.speed, 0, "");
    if (!text) return in_step("speed program", text.error());
    speed_program = std::move(*text);
  }
  for (int version : {1, 2}) {
    TableProvenance provenance;
    provenance.table_version = version;
    provenance.table_numbers = s.table_numbers;
    Result<std::string> program = render_x_table(s, design_table, 0, "", 0.0, version);
    if (!program) return program.error();
    if (design_table.y_table) {
      Result<std::string> y = render_y_table(s, *design_table.y_table, 0, "", version);
      if (!y) return y.error();
    }
    if (s.nc_main_template.empty()) continue;
    MainProgramSource main = main_source(s, "");
    if (design_program != nullptr) main.design_table_program = *design_program;
    Result<std::string> m = render_main_for_table(main, s.nc_dir / (s.nc_program + ".SPF"), *program);
    if (!m) return m.error();
    if (speed_program) {
      if (Status c = check_main_calls_speed_program(*m, s.nc_main_template_name, speed_program_name(s.nc_program));
          !c) {
        return c;
      }
    }
  }
  return {};
}

// The checks before the gauge for a pin: the geometry, the design's tables within the axis
// limits, and every template renders them (the Y table's and a main program coupling both).
Result<Prepared> prepare_pin(const JobSettings& s) {
  if (Status v = validate(*s.pin); !v) return in_step("part " + s.part.name, v.error());
  if (Status l = check_axis_limits(s.axis_limits); !l) return l.error();
  const bool with_y = s.pin->mode == PinMode::kCXY;
  if (with_y) {
    if (Status l = check_axis_limits(s.y_axis_limits); !l) return l.error();
    if (s.nc_y_template.empty()) {
      return make_error(ErrorCode::kInvalidInput, "part " + s.part.name +
                                                      " is a C-X-Y pin, but no Y table template is set: give one "
                                                      "(examples/sinumerik/pin_y_table.spf, [nc] y_template)");
    }
  }
  if (Status t = check_speed_template(s); !t) return t.error();
  const DegreeTable none{};
  Result<BuiltTable> design_table = build_pin_table(none, s);
  if (!design_table) return in_step("the design", design_table.error());
  if (Status r = check_programs_render(s, *design_table); !r) return r.error();
  // A round pin's gauge should read 0 everywhere: that is its design.
  return Prepared{PeriodicSpline::fit(none), DesignReading::interpolating(none)};
}

// Checks that need no gauge, so bad input costs no measurement: the design must make a
// table within the axis limits, and the template must render it.
Result<Prepared> prepare(const JobSettings& s) {
  if (s.table_kind == TableKind::kLinear || s.table_kind == TableKind::kSpline || s.table_kind == TableKind::kPoly) {
    const double steps = 360.0 / s.table_step_deg;
    if (!(s.table_step_deg > 0.0) || std::abs(steps - std::round(steps)) > 1e-9 || steps < 36) {
      return make_error(ErrorCode::kInvalidInput, "table step " + format_fixed(s.table_step_deg, 4) +
                                                      " deg must divide 360 into at least 36 steps");
    }
  }
  if (const int n = s.layer_design_table_number; n != 0) {
    if (s.pin) {
      return make_error(ErrorCode::kInvalidInput, "part " + s.part.name +
                                                      ": a crankpin has no correction layer ([correction_layer] is "
                                                      "a lobe's); remove it from the pin's part file");
    }
    if (s.speed) {
      return make_error(ErrorCode::kInvalidInput,
                        "part " + s.part.name +
                            ": a correction layer with a work speed program is not written by gaugeloop yet (its "
                            "main program would have to call the speed subprogram too); remove [speed] or "
                            "[correction_layer] from the part file");
    }
    if (n < 1 || n > 999 || n == s.table_numbers[0] || n == s.table_numbers[1]) {
      return make_error(ErrorCode::kInvalidInput, "part " + s.part.name + ": [correction_layer] design_table_number " +
                                                      std::to_string(n) +
                                                      " must be 1..999 and differ from the layer's table numbers " +
                                                      std::to_string(s.table_numbers[0]) + " and " +
                                                      std::to_string(s.table_numbers[1]) + " ([nc] table_numbers)");
    }
  }
  if (s.pin) return prepare_pin(s);
  if (Status l = check_axis_limits(s.axis_limits); !l) return l.error();
  Result<PeriodicSpline> design = PeriodicSpline::fit(s.design.angle_deg, s.design.lift_mm);
  if (!design) return in_step("design lift table " + s.design.source, design.error());
  if (Status t = check_speed_template(s); !t) return t.error();
  Result<DesignReading> design_reading = DesignReading::of_lobe(*design, s.part);
  if (!design_reading) return in_step("flat-probe reading", design_reading.error());
  // Zones that do not fit this lobe are a mistake in the part file: found before measuring.
  if (Result<std::vector<ZoneArc>> zones = zone_arcs(s.part.tolerances, design_reading->table()); !zones) {
    return in_step("part " + s.part.name + " tolerances", zones.error());
  }
  if (s.layer_design_table_number != 0) {
    // The design's whole table and its program; the layer's templates are checked with that
    // table in the layer's place (any table renders as any other: the layer itself is built
    // against the design table on the control, once measured).
    Result<LayerDesign> layer_design = build_layer_design(*design, s, "");
    if (!layer_design) return in_step("the design", layer_design.error());
    if (Status r = check_programs_render(s, layer_design->whole, &layer_design->program); !r) return r.error();
  } else {
    Result<BuiltTable> design_table = build_table(*design, s);
    if (!design_table) return in_step("the design", design_table.error());
    if (Status r = check_programs_render(s, *design_table); !r) return r.error();
  }
  return Prepared{std::move(*design), std::move(*design_reading)};
}

// Room a run and a program need, checked before measuring: a run of 3 revolutions is about
// 20 KB in the database, its WAL pages and the push journal's copy of the program some more,
// a program well under 64 KB. The margins cover a hundred revolutions and the largest tables,
// and the copy of the measurement kept in <data-dir>/unstored-runs/ (about 4 KB a revolution)
// if the database refuses the run.
constexpr std::uintmax_t kRoomForRunBytes = 2u * 1024u * 1024u;
constexpr std::uintmax_t kRoomForProgramBytes = 512u * 1024u;

Status check_room(const std::filesystem::path& dir, std::uintmax_t need, const std::string& what) {
  std::error_code ec;
  const std::filesystem::space_info room = std::filesystem::space(dir, ec);
  if (ec)
    return make_error(ErrorCode::kIo, what + " " + dir.string() + ": cannot tell the free space: " + ec.message());
  if (room.available < need) {
    return make_error(ErrorCode::kIo, what + " " + dir.string() + " has " + std::to_string(room.available / 1024) +
                                          " KB free, less than the " + std::to_string(need / 1024) +
                                          " KB a run needs; free space there, then measure");
  }
  return {};
}

}  // namespace

Status check_name(std::string_view name, std::string_view what) {
  if (name.empty() || name.size() > 64) {
    return make_error(ErrorCode::kInvalidInput, std::string(what) + " has " + std::to_string(name.size()) +
                                                    " characters; give 1 to 64 letters, digits, '_' or '-'");
  }
  for (std::size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(name[i]);
    if (std::isalnum(c) != 0 && c < 0x80) continue;
    if (c == '_' || c == '-') continue;
    char shown[16];
    std::snprintf(shown, sizeof shown, c >= 0x20 && c < 0x7f ? "'%c'" : "byte 0x%02X", c);
    return make_error(ErrorCode::kInvalidInput, std::string(what) + " '" +
                                                    std::string(name.substr(0, std::min<std::size_t>(i, 64))) +
                                                    "...' has " + shown + " at position " + std::to_string(i + 1) +
                                                    "; use only letters, digits, '_' or '-'");
  }
  return {};
}

Status check_nc_directory(const std::filesystem::path& nc_dir, const std::filesystem::path& nc_file) {
  std::error_code ec;
  std::filesystem::create_directories(nc_dir, ec);
  if (ec) return make_error(ErrorCode::kIo, "NC output directory " + nc_dir.string() + ": " + ec.message());
  // Something other than a file where the program goes (a directory, a device) would fail
  // the push after the run is stored.
  if (std::filesystem::exists(nc_file, ec) && !std::filesystem::is_regular_file(nc_file, ec)) {
    return make_error(ErrorCode::kIo, "NC program " + nc_file.string() +
                                          " exists but is not a file (a directory?); gaugeloop writes the curve "
                                          "table there: move it away, then measure");
  }
  std::string probe = (nc_dir / (atomic_temporary_prefix(nc_file) + "XXXXXX")).string();
  const int fd = ::mkstemp(probe.data());
  if (fd < 0) {
    return make_error(ErrorCode::kIo, "NC output directory " + nc_dir.string() + " is not writable by this user (" +
                                          std::strerror(errno) + "); fix its permissions or set another --nc-dir");
  }
  ::close(fd);
  ::unlink(probe.c_str());
  return check_room(nc_dir, kRoomForProgramBytes, "NC output directory");
}

Result<RunStore> open_store_for_push(const JobSettings& s, const std::filesystem::path& nc_file, StoreFindings* found) {
  if (Status d = check_nc_directory(s.nc_dir, nc_file); !d) return d.error();
  if (s.db_path != ":memory:") {
    const std::filesystem::path db_dir = std::filesystem::absolute(s.db_path).parent_path();
    std::error_code ec;
    std::filesystem::create_directories(db_dir, ec);  // RunStore::open would; the room is checked first
    if (Status r = check_room(db_dir, kRoomForRunBytes, "database directory"); !r) return r.error();
  }
  Result<RunStore> store = RunStore::open(s.db_path);
  if (!store) return store.error();
  store->set_nc_dir(s.nc_dir);
  // A damaged file is refused before the gauge is read: a correction read from it could be
  // anything, and a run stored into it could be lost.
  if (s.check_integrity) {
    if (Status sound = store->check_integrity(); !sound) return sound.error();
  }
  if (Status w = store->check_writable(); !w) return w.error();
  // A push interrupted earlier is recorded or abandoned before the table in force is read.
  NcFiles& files = s.nc_files ? *s.nc_files : real_nc_files();
  const MainProgramSource main = main_source(s, "");
  Result<ReconcileReport> r = reconcile_pushes(*store, nc_file, files, &main);
  if (!r) return r.error();
  if (found == nullptr) return store;
  // Only a main program gaugeloop writes is known to couple the table of the version pushed.
  for (const StaleMain& m : r->stale_mains) {
    if (m.nc_file == nc_file && !main.template_text.empty()) found->stale = m;
  }
  found->lost_commits = r->lost_commits;
  return store;
}

Result<Prepared> check_names_and_prepare(const JobSettings& s) {
  if (Status n = check_name(s.part.name, "part name"); !n) return n.error();
  if (Status n = check_name(s.nc_program, "NC program name"); !n) return n.error();
  if (Status n = check_name(s.machine, "machine name"); !n) return n.error();
  if (Status n = check_run_identity("serial", s.serial); !n) return n.error();
  if (Status n = check_run_identity("operator", s.operator_name); !n) return n.error();
  if (s.part_temperature) {
    Result<double> t = checked_part_temperature_c(s.part_temperature->temperature_c, "part temperature");
    if (!t) return t.error();
  }
  return prepare(s);
}

Status check_job_settings(const JobSettings& settings) {
  Result<Prepared> p = check_names_and_prepare(settings);
  if (!p) return p.error();
  return {};
}

}  // namespace gaugeloop

// gear ballbar, gear slides: the virtual gear grinder's slides on a ZY ballbar, and the control's
// compensation tables fitted to a ballbar test (docs/gears.md, "The slides").
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "cli/cli_common.h"
#include "cli/gear_loop.h"
#include "compensation/ballbar.h"
#include "config/gear_file.h"
#include "core/atomic_file.h"
#include "core/number_text.h"
#include "job/measure_job.h"
#include "job/slide_files.h"
#include "simulator/slide_ballbar.h"

namespace gaugeloop {

void print_ballbar_figures(const char* label, const BallbarFigures& f) {
  std::printf(
      "%s: roundness %.1f um (ISO 230-4, both directions, %d points), position error %.1f um, centre Y %+.1f "
      "Z %+.1f um\n",
      label, f.roundness_um, f.samples, f.position_error_um, f.centre_y_um, f.centre_z_um);
}

void print_slide_identification(const SlideIdentification& id) {
  std::printf("  fitted (residual %.2f um RMS, condition %.3g):\n", id.residual_rms_um, id.condition);
  std::printf(
      "    to the tables: scale mismatch (Y less Z) %+.1f um/m, squareness %+.1f um/m, Z's guide bowed %+.1f um "
      "in Y and Y's %+.1f um in Z over +-%.0f mm\n",
      id.scale_mismatch * 1e6, id.squareness * 1e6, id.y_straightness_per_mm * id.radius_mm * id.radius_mm * 1000.0,
      id.z_straightness_per_mm * id.radius_mm * id.radius_mm * 1000.0, id.radius_mm);
  if (id.model.y_screw_lead_mm > 0.0 || id.model.z_screw_lead_mm > 0.0) {
    std::printf("    screws' periodic errors: Y %.2f um at %.4g mm, Z %.2f um at %.4g mm\n",
                std::hypot(id.y_screw_sin_mm, id.y_screw_cos_mm) * 1000.0, id.model.y_screw_lead_mm,
                std::hypot(id.z_screw_sin_mm, id.z_screw_cos_mm) * 1000.0, id.model.z_screw_lead_mm);
  }
  std::printf(
      "    not a table's: servo mismatch (Z's lag less Y's) %+.3f ms, match the servo gains (MD32200 "
      "POSCTRL_GAIN); backlash Y %.1f um, Z %.1f um: the backlash compensation (MD32450 BACKLASH)\n",
      id.servo_mismatch_ms, id.y_backlash_um, id.z_backlash_um);
}

Result<SlideRound> run_slide_round(const SlideErrors& slides, RunStore& store, const std::filesystem::path& nc_dir,
                                   const SlideTableLayout& layout, const std::string& source) {
  Result<std::vector<SlideCompensationTable>> in_force = slide_tables_in_force(nc_dir, layout.names);
  if (!in_force) return in_force.error();
  SlideRound r;
  r.test_before = run_ballbar(slides, *in_force, layout.radius_mm, layout.feed_mm_per_min, 41.667, 0);
  Result<BallbarFigures> before = ballbar_figures(r.test_before);
  if (!before) return before.error();
  r.before = *before;
  Result<SlideIdentification> id =
      identify_slides(r.test_before, SlideModel{slides.y_screw_lead_mm, slides.z_screw_lead_mm});
  if (!id) return id.error();
  r.identified = *id;
  Result<std::vector<SlideCompensationTable>> tables =
      slide_tables(*id, layout.half_travel_mm, layout.step_mm, *in_force);
  if (!tables) return tables.error();
  if (Result<PushCompletion> p = push_slide_tables(store, nc_dir, *tables, layout.names, SlidePush{source}); !p) {
    return p.error();
  }
  // The ballbar again, with the tables as the control reads them from the NC directory.
  Result<std::vector<SlideCompensationTable>> loaded = slide_tables_in_force(nc_dir, layout.names);
  if (!loaded) return loaded.error();
  Result<BallbarFigures> after =
      ballbar_figures(run_ballbar(slides, *loaded, layout.radius_mm, layout.feed_mm_per_min, 41.667, 1));
  if (!after) return after.error();
  r.after = *after;
  return r;
}

namespace {

struct BallbarOptions {
  DataPaths paths;
  std::uint64_t machine_seed = 1;
  SlideTableLayout layout;  // the circle, its feed and the axes' names (not the tables' travel)
  std::string out_path;
};

int cmd_gear_ballbar(const BallbarOptions& o) {
  Result<std::vector<SlideCompensationTable>> in_force = slide_tables_in_force(o.paths.nc(), o.layout.names);
  if (!in_force) return report_error(in_force.error());
  const SlideErrors slides = seeded_slides(o.machine_seed);
  const BallbarTest t = run_ballbar(slides, *in_force, o.layout.radius_mm, o.layout.feed_mm_per_min);
  Result<BallbarFigures> f = ballbar_figures(t);
  if (!f) return report_error(f.error());
  std::printf("virtual gear grinder, machine seed %llu: ZY ballbar, radius %.4g mm, %.4g mm/min, both directions; %s\n",
              static_cast<unsigned long long>(o.machine_seed), o.layout.radius_mm, o.layout.feed_mm_per_min,
              in_force->empty() ? "no slide tables in force"
                                : ("the slide tables in " + o.paths.nc().string() + " loaded").c_str());
  print_ballbar_figures("ballbar", *f);
  if (o.out_path.empty()) return kExitOk;
  const std::string csv =
      ballbar_test_csv(t, "ZY ballbar of the virtual gear grinder, machine seed " + std::to_string(o.machine_seed));
  if (Status w = write_file_atomically(o.out_path, csv); !w) return report_file_error(w.error());
  std::printf("written %s: `gaugeloop gear slides --ballbar %s` fits the tables to it\n", o.out_path.c_str(),
              o.out_path.c_str());
  return kExitOk;
}

struct SlidesOptions {
  DataPaths paths;
  std::string ballbar_path;
  SlideModel model;
  SlideTableLayout layout;
  bool dry_run = false;
  bool overwrite_edited = false;
};

int cmd_gear_slides(const SlidesOptions& o) {
  Result<BallbarTest> t = read_ballbar_test_csv(o.ballbar_path, o.layout.radius_mm, o.layout.feed_mm_per_min);
  if (!t) return report_error(t.error());
  Result<BallbarFigures> f = ballbar_figures(*t);
  if (!f) return report_error(f.error());
  Result<SlideIdentification> id = identify_slides(*t, o.model);
  if (!id) return report_error(id.error());
  std::printf("%s: radius %.4g mm, %.4g mm/min\n", o.ballbar_path.c_str(), t->radius_mm, t->feed_mm_per_min);
  print_ballbar_figures("ballbar", *f);
  print_slide_identification(*id);
  const std::filesystem::path nc = o.paths.nc();
  Result<std::vector<SlideCompensationTable>> in_force = slide_tables_in_force(nc, o.layout.names);
  if (!in_force) return report_error(in_force.error());
  Result<std::vector<SlideCompensationTable>> tables =
      slide_tables(*id, o.layout.half_travel_mm, o.layout.step_mm, *in_force);
  if (!tables) return report_error(tables.error());
  if (o.dry_run) {
    std::printf("--dry-run: nothing written\n");
    return kExitOk;
  }
  std::error_code ec;
  std::filesystem::create_directories(nc, ec);
  const std::filesystem::path lec =
      std::filesystem::absolute(slide_file(nc, SlideTableKind::kLeadscrew)).lexically_normal();
  JobSettings js;
  js.db_path = o.paths.db();
  js.nc_dir = nc;
  Result<RunStore> store = open_store_for_push(js, lec);
  if (!store) return report_error(store.error());
  Result<PushCompletion> pushed = push_slide_tables(*store, lec.parent_path(), *tables, o.layout.names,
                                                    SlidePush{o.ballbar_path, o.overwrite_edited});
  if (!pushed) return report_error(pushed.error());
  std::printf(
      "pushed %s with %s beside it as slide tables version %d (%s): %zu points a table every %.4g mm over +-%.4g "
      "mm about the circle's centre, %s; `gaugeloop nc history --program %s` lists the versions, `nc "
      "rollback` puts an earlier pair back\n",
      lec.string().c_str(), slide_file(lec.parent_path(), SlideTableKind::kInterpolatory).string().c_str(),
      pushed->table_version, in_force->empty() ? "new" : "added to the tables in force",
      tables->front().error_mm.size(), o.layout.step_mm, o.layout.half_travel_mm,
      "load them with compensation off (MD32700 ENC_COMP_ENABLE and MD32710 CEC_ENABLE 0), then on",
      lec.filename().string().c_str());
  return kExitOk;
}

void add_layout_options(CLI::App& cmd, SlideTableLayout& l) {
  cmd.add_option("--radius-mm", l.radius_mm, "The ballbar circle's radius")
      ->capture_default_str()
      ->check(CLI::Range(10.0, 1000.0));
  cmd.add_option("--feed-mm-per-min", l.feed_mm_per_min, "The ballbar's feed")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 100000.0));
  cmd.add_option("--y-axis-name", l.names.y, "Y's machine axis name in the tables")->capture_default_str();
  cmd.add_option("--z-axis-name", l.names.z, "Z's machine axis name in the tables")->capture_default_str();
}

}  // namespace

void add_gear_slide_commands(CLI::App& gear, CommandAction& action) {
  auto bo = std::make_shared<BallbarOptions>();
  CLI::App* ballbar = gear.add_subcommand(
      "ballbar",
      "Run a ZY ballbar on the virtual gear grinder's slides (the machine of `demo --machine-seed`) with the slide "
      "tables in the NC directory loaded: roundness and position error; --out writes the test for `gear slides`");
  ballbar->add_option("--machine-seed", bo->machine_seed, "The virtual machine")->capture_default_str();
  add_layout_options(*ballbar, bo->layout);
  ballbar->add_option("--out", bo->out_path, "Write the test here (CSV: direction, angle_deg, radial_um)");
  add_data_options(*ballbar, bo->paths);
  ballbar->add_option("--nc-dir", bo->paths.nc_dir, "Directory of the slide tables in force [<data-dir>/nc]");
  ballbar->callback([&action, bo] { action = [bo] { return cmd_gear_ballbar(*bo); }; });

  auto so = std::make_shared<SlidesOptions>();
  CLI::App* slides = gear.add_subcommand(
      "slides",
      "Fit the slides' errors to a ZY ballbar test run both ways and write the control's compensation tables: "
      "LEC (AX_EEC.INI) for Y's and Z's own errors, CEC (NC_CEC.INI) for Y over Z and Z over Y, added to the "
      "tables in force; the servo mismatch and backlash are reported, not tabled");
  slides->add_option("--ballbar", so->ballbar_path, "The test, CSV: direction (ccw, cw), angle_deg, radial_um")
      ->required();
  slides
      ->add_option("--y-screw-lead-mm", so->model.y_screw_lead_mm,
                   "Y's ball screw lead, to fit its periodic error (0: none)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  slides->add_option("--z-screw-lead-mm", so->model.z_screw_lead_mm, "Z's ball screw lead (0: none)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  slides
      ->add_option("--half-travel-mm", so->layout.half_travel_mm,
                   "The tables reach this far either side of the circle's centre")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 10000.0));
  slides->add_option("--step-mm", so->layout.step_mm, "Between the tables' points")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 1000.0));
  add_layout_options(*slides, so->layout);
  slides->add_flag("--dry-run", so->dry_run, "Fit and print; write nothing");
  slides->add_flag("--overwrite-edited", so->overwrite_edited,
                   "Overwrite slide tables on the control that were edited by hand (they are refused otherwise)");
  add_data_options(*slides, so->paths);
  slides->add_option("--nc-dir", so->paths.nc_dir,
                     "Directory the tables are pushed to [<data-dir>/nc]; the push is kept in <data-dir>'s database");
  slides->callback([&action, so] { action = [so] { return cmd_gear_slides(*so); }; });
}

}  // namespace gaugeloop

// The closed loop for a gear on the virtual gear grinder: grind -> measure the lead (the
// machine's flank probe over Modbus TCP on loopback, core/gear_probe_registers.h) -> identify
// the mesh error along the stroke -> push the corrected stroke -> grind (docs/gears.md, "The
// loop"). Each gear is ground from the stroke program in force, read back from the NC
// directory as the control reads it; the first from a stroke without compensation.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "cli/cli_common.h"
#include "compensation/ballbar.h"
#include "compensation/gear_lead.h"
#include "config/gear_file.h"
#include "job/gear_stroke.h"
#include "nc_out/slide_compensation.h"
#include "report/gear_characteristics.h"
#include "simulator/gear_grinder.h"
#include "simulator/slide_ballbar.h"

namespace gaugeloop {

struct GearLoopSettings {
  GearPartFile part;
  GearMachineErrors machine;
  int iterations = 2;                                 // corrections; iterations + 1 gears are ground
  std::vector<int> gaps = {1, 20, 40, 60};            // the tooth gaps the checker measures, both flanks
  double lead_step_mm = 0.5;                          // the checker's spacing across the face
  std::string machine_name = "virtual gear grinder";  // as the gear runs are stored
  GearStrokeSettings stroke;                          // store, nc_file, main program, grids, feed
};

// What ISO 1328-1 makes of a gear's lead traces, over every trace measured.
struct GearLeadSummary {
  double total_mean_um = 0.0;  // F_beta
  double total_max_um = 0.0;
  double form_mean_um = 0.0;              // f_f_beta
  double slope_mean_abs_um = 0.0;         // |f_H_beta|
  int tolerance_class = 0;                // of total_max_um (helix_tolerance_class)
  Verdict verdict = Verdict::kNotJudged;  // against the part's tolerance_class
};

struct GearLoopIteration {
  int iteration = 0;
  int ground_from_version = 0;                   // the stroke version in force when it was ground
  GearLeadSummary measured;                      // as the checker measured it (its noise included)
  std::int64_t gear_run_id = 0;                  // the measured gear as stored; 0: no store
  GearLeadSummary ground;                        // the gear as ground: the same traces without the checker's noise
  GearProfileFigures profile;                    // the checker's profiles of the same gaps, with its noise
  std::optional<MeshIdentification> identified;  // not after the last gear
  int pushed_version = 0;                        // the corrected stroke's version; 0: none
  double sim_max_abs_deg = 0.0;                  // of the corrected stroke
};

// Summarises traces as judge_gear (job/gear_run.h) judges them; errors: judge_gear's.
Result<GearLeadSummary> summarize_lead(const std::vector<LeadTrace>& traces, const GearPart& part,
                                       std::optional<int> required_class = std::nullopt);

// Runs the loop; `on_gear` (may be empty) sees each gear as it is measured (and corrected).
// With a store (settings.stroke.store) each gear measured is kept as a gear run before the
// stroke corrected from it is pushed, and the run records the version pushed.
// Errors: the part's, the push's (push_gear_stroke), the grinder's reading of the stroke.
Result<std::vector<GearLoopIteration>> run_gear_loop(const GearLoopSettings& settings,
                                                     const std::function<void(const GearLoopIteration&)>& on_gear);

// `gaugeloop demo --part <gear file>`: the loop above on a machine drawn from machine_seed, into
// the data directory's database and NC directory, every gear printed; returns the exit status.
struct GearDemoOptions {
  DataPaths paths;
  std::string part_path;
  int iterations = 2;
  std::uint64_t machine_seed = 1;
  double z_increments_per_mm = 10000.0;
};
int run_gear_demo(const GearDemoOptions& o);

// The slides' tables and the ballbar they are fitted to (commands_slides.cc).
struct SlideTableLayout {
  double radius_mm = 100.0;  // the ballbar's circle
  double feed_mm_per_min = 1000.0;
  double half_travel_mm = 150.0;  // the tables either side of the circle's centre
  double step_mm = 2.0;
  SlideAxisNames names;
};

// The slides' round of the demo: a ZY ballbar on the virtual machine's slides with the tables in
// force in `nc_dir`, their geometry fitted, the tables written there (added to those in force),
// and the ballbar again with them as read back. Errors: the tables in force's, the fit's, the
// push's (nothing is written when the fit is refused).
struct SlideRound {
  BallbarTest test_before;
  BallbarFigures before;
  SlideIdentification identified;
  BallbarFigures after;
};
Result<SlideRound> run_slide_round(const SlideErrors& slides, RunStore& store, const std::filesystem::path& nc_dir,
                                   const SlideTableLayout& layout, const std::string& source);
void print_ballbar_figures(const char* label, const BallbarFigures& f);
void print_slide_identification(const SlideIdentification& id);

// gear ballbar and gear slides, under `gear`.
void add_gear_slide_commands(CLI::App& gear, CommandAction& action);

}  // namespace gaugeloop

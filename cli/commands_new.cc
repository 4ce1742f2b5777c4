// nc new: the first program of a part from its drawing, with its preview.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "cli/cli_common.h"
#include "cli/measure_options.h"
#include "core/atomic_file.h"
#include "core/number_text.h"
#include "job/nc_new.h"
#include "nc_out/main_program.h"
#include "report/program_preview.h"

namespace gaugeloop {
namespace {

struct NewOptions {
  MeasureOptions measure;
  bool replace = false;
  bool preview_only = false;
  std::string by;
  std::string csv_path;
  std::string plot_path;
};

std::string fixed(double v, int d) { return format_fixed(v, d); }

// The candidates a default table weighed, the chosen one marked.
void print_candidates(const char* axis, const std::vector<TableCandidate>& candidates, const CurveTable& chosen,
                      double bound_um) {
  if (candidates.empty()) return;
  std::printf("  %s table choices (bound %.3f um):\n", axis, bound_um);
  std::printf("    %-18s %-13s %9s %7s %12s\n", "writer", "interpolation", "seam C", "blocks", "error um");
  for (const TableCandidate& c : candidates) {
    if (!c.table) {
      std::printf("    %-18s refused: %s\n", c.writer.c_str(), c.refused.c_str());
      continue;
    }
    const CurveTable& t = *c.table;
    const bool is_chosen = t.writer == chosen.writer && t.block_count() == chosen.block_count();
    std::printf("    %-18s %-13s %9.3f %7d %12.3f%s%s\n", c.writer.c_str(),
                std::string(interpolation_name(t.interpolation)).c_str(), t.points.front().c_deg, t.block_count(),
                t.error.max_abs_um, t.error.max_abs_um > bound_um ? "  over the bound" : "",
                is_chosen ? "  <- chosen" : "");
  }
}

void print_table(const char* what, const CurveTable& t) {
  std::printf("  %-16s %d blocks (%s, %s), seam C%.3f, command position error %.3f um at C%.2f\n", what,
              t.block_count(), t.writer.c_str(), std::string(interpolation_name(t.interpolation)).c_str(),
              t.points.front().c_deg, t.error.max_abs_um, t.error.at_c_deg);
}

void print_preview(const ProgramPreview& p, const JobSettings& s) {
  const BuiltTable& b = p.built;
  print_table(b.y_table ? "X table" : "table", b.table);
  if (b.y_table) print_table("Y table", *b.y_table);
  print_candidates("X", p.x_candidates, b.table, s.table_choice.bound_um);
  if (b.y_table) print_candidates("Y", p.y_candidates, *b.y_table, s.table_choice.bound_um);
  if (b.speed) {
    std::printf("  speed program    %d feed blocks (speed error %.2f %%), one turn %.3f s against %.3f s at %.0f rpm\n",
                b.speed->profile.block_count(), b.speed->profile.error.max_speed_error_percent,
                b.speed->plan.cycle_time_s, b.speed->plan.constant_cycle_time_s, s.speed->base_speed_rpm);
  }
  std::string passes;
  for (const InfeedPass& pass : p.infeed.passes) {
    if (!passes.empty()) passes += ", ";
    passes += pass.name + " " + std::to_string(pass.turns) + " turns" +
              (pass.infeed_mm > 0.0 ? " " + fixed(pass.infeed_mm, 4) + " mm" : std::string());
  }
  std::printf("  passes           %s; start offset %.4f mm (stock %.4f + air gap %.4f)\n", passes.c_str(),
              p.infeed.start_offset_mm, s.cycle.stock_mm, s.cycle.air_gap_mm);
  std::printf("  cycle            %d turns, %.3f s a turn%s: %.1f s\n", p.infeed.turns(), p.turn_time_s,
              b.speed ? " under the speed program" : (" at " + fixed(p.work_speed_rpm, 0) + " rpm").c_str(),
              p.cycle_time_s);
}

Status write_preview_files(const NewOptions& o, const ProgramPreview& p, const JobSettings& s) {
  if (!o.csv_path.empty()) {
    if (Status w = write_file_atomically(o.csv_path, preview_csv(p)); !w) return w;
    std::printf("  preview CSV      %s\n", o.csv_path.c_str());
  }
  if (o.plot_path.empty()) return {};
  const ProgramPreviewPage page = preview_page(p, s);
  if (Status w = write_program_preview(page, o.plot_path); !w) return w;
  std::printf("  preview picture  %s\n", o.plot_path.c_str());
  return {};
}

int cmd_nc_new(const NewOptions& o) {
  Result<LoadedPart> lp = load_part(o.measure.part_path);
  if (!lp) return report_error(lp.error());
  Result<JobSettings> js = job_settings_for(*lp, o.measure, /*build_on_table_in_force=*/false);
  if (!js) return report_error(js.error());
  const std::string from = o.measure.part_path.empty() ? std::string("the built-in sample") : o.measure.part_path;
  std::printf("new program %s for %s %s %d (%s)\n", js->nc_program.c_str(), js->part.name.c_str(),
              js->pin ? "pin" : "lobe", js->part.lobe, from.c_str());
  if (o.preview_only) {
    Result<ProgramPreview> p = preview_new_program(*js);
    if (!p) return report_error(p.error());
    print_preview(*p, *js);
    if (Status w = write_preview_files(o, *p, *js); !w) return report_error(w.error());
    std::printf("  nothing written (--preview)\n");
    return kExitOk;
  }
  NewProgramOptions options;
  options.replace = o.replace;
  options.by = o.by;
  options.from_file = from;
  Result<NewProgramReport> r = write_new_program(*js, options);
  if (!r) return report_error(r.error());
  print_preview(r->preview, *js);
  if (Status w = write_preview_files(o, r->preview, *js); !w) return report_error(w.error());
  std::string files;
  for (const std::filesystem::path& f : r->files) files += (files.empty() ? "" : ", ") + f.filename().string();
  std::printf("  written          version %d of %s: %s, each read back\n", r->table_version,
              r->nc_file.string().c_str(), files.c_str());
  std::printf("  next             grind part 0 with it, then `gaugeloop measure --ground-with %d ...`\n",
              r->table_version);
  return kExitOk;
}

}  // namespace

void add_nc_new_command(CLI::App& nc, CommandAction& action) {
  auto o = std::make_shared<NewOptions>();
  CLI::App* cmd = nc.add_subcommand(
      "new",
      "Write the first program of a part from its drawing: the table(s), speed and main program as a push writes "
      "them, version 1 with no run behind it; --preview shows it without writing.");
  add_program_options(*cmd, o->measure);
  cmd->add_option("--part", o->measure.part_path, "Part file (TOML): a cam lobe or a crankpin [built-in sample lobe]");
  cmd->add_flag("--replace", o->replace,
                "Write it even though the program has a history or a file gaugeloop did not write is there (the "
                "history stays; the new program is its next version)");
  cmd->add_flag("--preview", o->preview_only, "Show the program and the choices tried; write nothing to the control");
  cmd->add_option("--by", o->by, "Who writes it, for the history [$USER]");
  cmd->add_option("--csv", o->csv_path, "Write the profile per degree of C (X, X', X'', speeds, command error) as CSV");
  cmd->add_option("--plot", o->plot_path, "Write the preview picture: .pdf, .svg or .png");
  cmd->callback([&action, o] {
    if (o->by.empty()) {
      const char* user = std::getenv("USER");
      o->by = user != nullptr && *user != '\0' ? user : "operator";
    }
    action = [o] { return cmd_nc_new(*o); };
  });
}

}  // namespace gaugeloop

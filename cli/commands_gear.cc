// gear ...: the worm-wheel generating grinder's gearbox for a gear part (docs/gears.md).
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "cli/cli_common.h"
#include "compensation/gear_coupling.h"
#include "config/gear_file.h"

namespace gaugeloop {
namespace {

struct CouplingOptions {
  std::string part_path;
  bool json = false;
};

int cmd_gear_coupling(const CouplingOptions& o) {
  Result<GearPartFile> gf = read_gear_part_file(o.part_path);
  if (!gf) return report_error(gf.error());
  const GearPart& p = gf->part;
  const GearCoupling k = gear_coupling(p);
  if (o.json) {
    print_json(nlohmann::json{{"part", gf->name},
                              {"nc_program", gf->nc_program},
                              {"s_bc", k.s_bc},
                              {"s_zc_deg_per_mm", k.s_zc_deg_per_mm},
                              {"s_yc_deg_per_mm", k.s_yc_deg_per_mm},
                              {"s_sim_c", k.s_sim_c},
                              {"setting_angle_deg", k.setting_angle_deg},
                              {"lead_angle_deg", k.lead_angle_deg},
                              {"worm_lead_mm", k.worm_lead_mm},
                              {"gear_pitch_diameter_mm", k.gear_pitch_diameter_mm},
                              {"transverse_pitch_mm", k.transverse_pitch_mm}});
    return kExitOk;
  }
  const GearGeometry& g = p.gear;
  std::printf("gear %s: module %.4g mm, %d teeth, pressure angle %.4g deg, helix %.4g deg %s, face %.4g mm\n",
              gf->name.c_str(), g.normal_module_mm, g.teeth, g.pressure_angle_deg, g.helix_angle_deg,
              g.helix_angle_deg == 0.0 ? "(spur)" : std::string(hand_name(g.hand)).c_str(), g.face_width_mm);
  std::printf("worm: %d start%s, pitch diameter %.4g mm, %s hand, lead angle %.6f deg, lead %.6f mm\n", p.worm.starts,
              p.worm.starts == 1 ? "" : "s", p.worm.pitch_diameter_mm, std::string(hand_name(p.worm.hand)).c_str(),
              k.lead_angle_deg, k.worm_lead_mm);
  std::printf("gear pitch diameter %.6f mm, transverse pitch %.6f mm; worm set at %.6f deg\n", k.gear_pitch_diameter_mm,
              k.transverse_pitch_mm, k.setting_angle_deg);
  std::printf("electronic gearbox, C following (degrees of C):\n");
  std::printf("  S_BC   %+.12f deg per deg of B\n", k.s_bc);
  std::printf("  S_ZC   %+.12f deg per mm of Z\n", k.s_zc_deg_per_mm);
  std::printf("  S_YC   %+.12f deg per mm of Y\n", k.s_yc_deg_per_mm);
  std::printf("  SIM1   %+.12f deg per deg of SIM1\n", k.s_sim_c);
  std::printf("compensation through SIM1: dSIM = S_YC e_Y + S_ZC e_Z + S_BC e_B - e_C (e: axis errors)\n");
  return kExitOk;
}

}  // namespace

void add_gear_commands(CLI::App& app, CommandAction& action) {
  CLI::App* gear = app.add_subcommand(
      "gear", "Gears ground by a worm wheel on a generating grinder: the electronic gearbox (docs/gears.md)");
  gear->require_subcommand(1);
  auto o = std::make_shared<CouplingOptions>();
  CLI::App* cmd = gear->add_subcommand(
      "coupling",
      "Print the gearbox's coupling factors for a gear part (C following B, Z, Y and the virtual axis SIM1), the "
      "worm's setting angle and lead, derived from the generating motion");
  cmd->add_option("--part", o->part_path, "Gear part file (TOML with [gear]), e.g. examples/gear_71.toml")->required();
  cmd->add_flag("--json", o->json, "Print the factors as JSON");
  cmd->callback([&action, o] { action = [o] { return cmd_gear_coupling(*o); }; });
}

}  // namespace gaugeloop

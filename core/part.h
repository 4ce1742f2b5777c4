// A part as the shop describes it: the lobe's design lift and the geometry that turns it
// into a wheel path. Read from a TOML file by app/; plain data here.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "core/tolerance.h"

namespace gaugeloop {

enum class FollowerKind {
  kFlat,       // flat-faced follower
  kRoller,     // roller follower of radius follower_radius_mm
  kKnifeEdge,  // knife edge: a roller of radius 0
};

struct Part {
  std::string name;                  // shown in reports and stored with each run
  int lobe = 1;                      // lobe number on the camshaft, 1-based
  std::filesystem::path lift_table;  // CSV `angle_deg,lift_mm`, cam frame
  FollowerKind follower = FollowerKind::kFlat;
  double follower_radius_mm = 0.0;     // roller radius; ignored for flat and knife edge
  double base_circle_radius_mm = 0.0;  // rb
  double wheel_radius_mm = 200.0;      // rw, the grinding wheel
  // Machine angle C = rotation_sense * psi + c_offset_deg (the cam-grinding kinematics).
  int rotation_sense = 1;     // +1 or -1
  double c_offset_deg = 0.0;  // c0: the C angle of the lobe nose
  // The gauge probe sits this far (machine degrees) from the wheel contact, in the sense of C.
  double probe_offset_deg = 0.0;
  // What the lobe is judged against ([tolerance] in the part file); none: nothing judged.
  LobeTolerances tolerances;
  // The drawing the part is made to (part file drawing_number, drawing_revision), printed on
  // its reports; empty: not given.
  std::string drawing_number;
  std::string drawing_revision;
};

std::string_view follower_kind_name(FollowerKind kind);

// The cam angle (degrees, cam frame, in [0, 360)) under the gauge probe when the work
// spindle stands at machine angle `c_deg`: beta = s * (C - c0 - probe_offset).
// Acquisition bins by C; analysis and the simulator use this one mapping to the cam frame.
double cam_angle_at_probe_deg(const Part& part, double c_deg);

}  // namespace gaugeloop

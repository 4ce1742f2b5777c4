// Names of follower kinds as they appear in part files.
#include "core/part.h"

#include <cmath>

namespace gaugeloop {

std::string_view follower_kind_name(FollowerKind kind) {
  switch (kind) {
    case FollowerKind::kFlat:
      return "flat";
    case FollowerKind::kRoller:
      return "roller";
    case FollowerKind::kKnifeEdge:
      return "knife_edge";
  }
  return "unknown";
}

double cam_angle_at_probe_deg(const Part& part, double c_deg) {
  double beta = part.rotation_sense * (c_deg - part.c_offset_deg - part.probe_offset_deg);
  beta = std::fmod(beta, 360.0);
  if (beta < 0.0) beta += 360.0;
  if (beta >= 360.0) beta -= 360.0;  // -1e-17 + 360 rounds to 360
  return beta;
}

}  // namespace gaugeloop

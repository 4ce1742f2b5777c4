// A ballbar test's figures and the slides' errors fitted to it.
#include "compensation/ballbar.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "compensation/least_squares.h"
#include "core/angles.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

Status check_circle(const BallbarCircle& c, const char* which) {
  if (c.angle_deg.size() != c.radial_um.size()) {
    return make_error(ErrorCode::kInvalidInput, std::string("the ") + which + " circle has " +
                                                    std::to_string(c.angle_deg.size()) + " angles and " +
                                                    std::to_string(c.radial_um.size()) + " radial deviations");
  }
  for (std::size_t i = 0; i < c.angle_deg.size(); ++i) {
    if (!std::isfinite(c.angle_deg[i]) || !std::isfinite(c.radial_um[i])) {
      return make_error(ErrorCode::kInvalidInput, std::string("the ") + which + " circle's point " +
                                                      std::to_string(i + 1) + " is not a finite number");
    }
  }
  return {};
}

Status check_test(const BallbarTest& t) {
  if (!(t.radius_mm > 0.0) || !std::isfinite(t.radius_mm)) {
    return make_error(ErrorCode::kInvalidInput,
                      "the ballbar's radius must be positive, not " + format_fixed(t.radius_mm, 3) + " mm");
  }
  if (!(t.feed_mm_per_min > 0.0) || !std::isfinite(t.feed_mm_per_min)) {
    return make_error(ErrorCode::kInvalidInput,
                      "the ballbar's feed must be positive, not " + format_fixed(t.feed_mm_per_min, 1) + " mm/min");
  }
  if (Status s = check_circle(t.ccw, "counter-clockwise"); !s) return s;
  if (Status s = check_circle(t.cw, "clockwise"); !s) return s;
  if (t.ccw.angle_deg.size() + t.cw.angle_deg.size() < 8) {
    return make_error(ErrorCode::kInvalidInput, "the ballbar test has " +
                                                    std::to_string(t.ccw.angle_deg.size() + t.cw.angle_deg.size()) +
                                                    " points: at least 8 are needed, a full circle each way");
  }
  return {};
}

// Calls f(angle_rad, radial_um, direction) for every point, counter-clockwise (+1) first.
template <typename F>
void each_point(const BallbarTest& t, F&& f) {
  for (std::size_t i = 0; i < t.ccw.angle_deg.size(); ++i) f(t.ccw.angle_deg[i] * kPi / 180.0, t.ccw.radial_um[i], 1.0);
  for (std::size_t i = 0; i < t.cw.angle_deg.size(); ++i) f(t.cw.angle_deg[i] * kPi / 180.0, t.cw.radial_um[i], -1.0);
}

double sign_of(double v) { return v > 0.0 ? 1.0 : v < 0.0 ? -1.0 : 0.0; }

// The fit's columns, each a named term and its radial deviation (um) per unit at a point.
enum Column {
  kRadius,  // the bar's length: the mean scale of both axes
  kCentreY,
  kCentreZ,
  kScaleMismatch,
  kSquareness,
  kYStraightness,
  kZStraightness,
  kServoMismatch,
  kYBacklash,
  kZBacklash,
  kYScrewSin,
  kYScrewCos,
  kZScrewSin,
  kZScrewCos,
  kColumns
};

const char* column_name(int c) {
  static const char* const names[kColumns] = {"the bar's length",
                                              "the centre's Y",
                                              "the centre's Z",
                                              "the scale mismatch",
                                              "the squareness",
                                              "Z's guide's bow (Y over Z)",
                                              "Y's guide's bow (Z over Y)",
                                              "the servo mismatch",
                                              "Y's backlash",
                                              "Z's backlash",
                                              "Y's screw",
                                              "Y's screw",
                                              "Z's screw",
                                              "Z's screw"};
  return names[c];
}

// The radial deviation (um) per unit of each column at angle a (rad), direction d, the feed
// v (mm/s), radius r (mm). Geometric units in mm (x 1000 to um), the lag in ms, play in um.
void row_of(double a, double d, double r, double v, const SlideModel& m, double* out) {
  const double c = std::cos(a), s = std::sin(a), y = r * c, z = r * s;
  out[kRadius] = 1.0;
  out[kCentreY] = c;
  out[kCentreZ] = s;
  out[kScaleMismatch] = 1000.0 * y * c;  // Y's scale error less Z's, Z's mean in the bar's length
  out[kSquareness] = 1000.0 * z * c;
  out[kYStraightness] = 1000.0 * z * z * c;
  out[kZStraightness] = 1000.0 * y * y * s;
  // Each axis lags its command by its velocity times its lag: along the path, and radially
  // only by the difference of the two; Z less Y, in ms.
  out[kServoMismatch] = -1000.0 * d * v * s * c;
  // An axis stands behind by half its play in the direction it moves: Y moves as -d sin(a),
  // Z as d cos(a).
  out[kYBacklash] = 0.5 * d * sign_of(s) * c;
  out[kZBacklash] = -0.5 * d * sign_of(c) * s;
  const double py = m.y_screw_lead_mm > 0.0 ? 2.0 * kPi * y / m.y_screw_lead_mm : 0.0;
  const double pz = m.z_screw_lead_mm > 0.0 ? 2.0 * kPi * z / m.z_screw_lead_mm : 0.0;
  out[kYScrewSin] = m.y_screw_lead_mm > 0.0 ? 1000.0 * std::sin(py) * c : 0.0;
  out[kYScrewCos] = m.y_screw_lead_mm > 0.0 ? 1000.0 * std::cos(py) * c : 0.0;
  out[kZScrewSin] = m.z_screw_lead_mm > 0.0 ? 1000.0 * std::sin(pz) * s : 0.0;
  out[kZScrewCos] = m.z_screw_lead_mm > 0.0 ? 1000.0 * std::cos(pz) * s : 0.0;
}

// What separates the terms of a group that acts alike.
std::string what_separates(const std::vector<int>& group) {
  auto has = [&](int c) { return std::find(group.begin(), group.end(), c) != group.end(); };
  if (has(kServoMismatch) || has(kYBacklash) || has(kZBacklash)) {
    return "run the circle both ways (counter-clockwise and clockwise): the servo mismatch and the backlash turn "
           "over with the direction, the geometry does not";
  }
  if (has(kYScrewSin) || has(kYScrewCos) || has(kZScrewSin) || has(kZScrewCos)) {
    return "check the screw's lead (--y-screw-lead-mm, --z-screw-lead-mm) against the machine's documentation, or "
           "leave it out (0)";
  }
  return "a larger circle, or a laser for the axes' own scales";
}

}  // namespace

Result<BallbarFigures> ballbar_figures(const BallbarTest& t) {
  if (Status s = check_test(t); !s) return s.error();
  // The least-squares centre and radius: radial = r0 + cy cos + cz sin.
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d aty = Eigen::Vector3d::Zero();
  double lo = 1e300, hi = -1e300;
  int n = 0;
  each_point(t, [&](double a, double r, double) {
    const Eigen::Vector3d row(1.0, std::cos(a), std::sin(a));
    ata += row * row.transpose();
    aty += row * r;
    lo = std::min(lo, r);
    hi = std::max(hi, r);
    ++n;
  });
  const Eigen::Vector3d x = ata.ldlt().solve(aty);
  double flo = 1e300, fhi = -1e300;
  each_point(t, [&](double a, double r, double) {
    const double left = r - x(1) * std::cos(a) - x(2) * std::sin(a);
    flo = std::min(flo, left);
    fhi = std::max(fhi, left);
  });
  BallbarFigures f;
  f.roundness_um = fhi - flo;
  f.position_error_um = hi - lo;
  f.centre_y_um = x(1);
  f.centre_z_um = x(2);
  f.samples = n;
  return f;
}

Result<SlideIdentification> identify_slides(const BallbarTest& t, const SlideModel& m) {
  if (Status s = check_test(t); !s) return s.error();
  for (const double lead : {m.y_screw_lead_mm, m.z_screw_lead_mm}) {
    if (!(lead >= 0.0) || !std::isfinite(lead)) {
      return make_error(
          ErrorCode::kInvalidInput,
          "a screw's lead must be positive (or 0: no periodic error fitted), not " + format_fixed(lead, 3));
    }
  }
  const int rows = static_cast<int>(t.ccw.angle_deg.size() + t.cw.angle_deg.size());
  std::vector<int> used;
  for (int c = 0; c < kColumns; ++c) {
    const bool y_screw = c == kYScrewSin || c == kYScrewCos;
    const bool z_screw = c == kZScrewSin || c == kZScrewCos;
    if ((y_screw && !(m.y_screw_lead_mm > 0.0)) || (z_screw && !(m.z_screw_lead_mm > 0.0))) continue;
    used.push_back(c);
  }
  const int columns = static_cast<int>(used.size());
  Eigen::MatrixXd a(rows, columns);
  Eigen::VectorXd y(rows);
  const double v = t.feed_mm_per_min / 60.0 / 1000.0;  // mm per ms
  int row = 0;
  each_point(t, [&](double ang, double r, double d) {
    double full[kColumns];
    row_of(ang, d, t.radius_mm, v, m, full);
    for (int j = 0; j < columns; ++j) a(row, j) = full[used[static_cast<std::size_t>(j)]];
    y(row) = r;
    ++row;
  });
  const ScaledFit fit = scaled_least_squares(a, y);
  std::string what;
  for (const Eigen::VectorXd& vi : fit.null_directions) {
    std::vector<int> group;
    std::string names;
    for (int j = 0; j < columns; ++j) {
      if (std::abs(vi(j)) <= 1e-6) continue;
      const int c = used[static_cast<std::size_t>(j)];
      group.push_back(c);
      const std::string name = column_name(c);
      if (names.find(name) == std::string::npos) names += (names.empty() ? "" : " and ") + name;
    }
    if (group.empty()) continue;
    what += (what.empty() ? "" : "; ") + names + (group.size() > 1 ? " act alike: " : " is not seen: ") +
            what_separates(group);
  }
  if (!what.empty()) {
    return make_error(ErrorCode::kRefused,
                      "the ballbar test cannot tell these apart: " + what + ". Nothing was written");
  }
  const Eigen::VectorXd& x = fit.x;
  const Eigen::VectorXd res = a * x - y;
  auto value = [&](int c) {
    const auto it = std::find(used.begin(), used.end(), c);
    return it == used.end() ? 0.0 : x(static_cast<int>(it - used.begin()));
  };
  SlideIdentification id;
  id.scale_mismatch = value(kScaleMismatch);
  id.squareness = value(kSquareness);
  id.y_straightness_per_mm = value(kYStraightness);
  id.z_straightness_per_mm = value(kZStraightness);
  id.y_screw_sin_mm = value(kYScrewSin);
  id.y_screw_cos_mm = value(kYScrewCos);
  id.z_screw_sin_mm = value(kZScrewSin);
  id.z_screw_cos_mm = value(kZScrewCos);
  id.servo_mismatch_ms = value(kServoMismatch);
  id.y_backlash_um = value(kYBacklash);
  id.z_backlash_um = value(kZBacklash);
  id.model = m;
  id.radius_mm = t.radius_mm;
  id.residual_rms_um = std::sqrt(res.squaredNorm() / rows);
  id.condition = fit.condition;
  id.samples = rows;
  return id;
}

Result<std::vector<SlideCompensationTable>> slide_tables(const SlideIdentification& id, double half_travel_mm,
                                                         double step_mm,
                                                         const std::vector<SlideCompensationTable>& in_force) {
  if (!(half_travel_mm > 0.0) || !(step_mm > 0.0) || !std::isfinite(half_travel_mm) || !std::isfinite(step_mm) ||
      2.0 * half_travel_mm / step_mm > 10000.0) {
    return make_error(ErrorCode::kInvalidInput, "the tables' travel (" + format_fixed(half_travel_mm, 3) +
                                                    " mm each side) and step (" + format_fixed(step_mm, 3) +
                                                    " mm) must be positive, with at most 10,000 points a table");
  }
  const int points = static_cast<int>(std::floor(2.0 * half_travel_mm / step_mm + 1e-9)) + 1;
  const double min_mm = -step_mm * (points - 1) / 2.0;
  const SlideModel& m = id.model;
  auto screw = [](double lead, double s, double c, double p) {
    if (!(lead > 0.0)) return 0.0;
    const double x = 2.0 * kPi * p / lead;
    return s * std::sin(x) + c * std::cos(x) - c;  // 0 at the centre
  };
  struct Layout {
    SlideTableKind kind;
    char input, output;
  };
  const Layout layouts[] = {{SlideTableKind::kLeadscrew, 'Y', 'Y'},
                            {SlideTableKind::kLeadscrew, 'Z', 'Z'},
                            {SlideTableKind::kInterpolatory, 'Z', 'Y'},
                            {SlideTableKind::kInterpolatory, 'Y', 'Z'}};
  if (!in_force.empty()) {
    bool same = in_force.size() == 4;
    for (std::size_t i = 0; same && i < 4; ++i) {
      const SlideCompensationTable& f = in_force[i];
      same = f.kind == layouts[i].kind && f.input_axis == layouts[i].input && f.output_axis == layouts[i].output &&
             f.error_mm.size() == static_cast<std::size_t>(points) && std::abs(f.min_mm - min_mm) < 1e-9 &&
             std::abs(f.step_mm - step_mm) < 1e-9;
    }
    if (!same) {
      return make_error(ErrorCode::kInvalidInput,
                        "the slide tables in force are not laid out as these would be (the same four tables, " +
                            std::to_string(points) + " points from " + format_fixed(min_mm, 3) + " mm every " +
                            format_fixed(step_mm, 3) +
                            " mm): give the travel and step they were written with, or start from none");
    }
  }
  std::vector<SlideCompensationTable> out;
  for (std::size_t i = 0; i < 4; ++i) {
    SlideCompensationTable t;
    t.kind = layouts[i].kind;
    t.input_axis = layouts[i].input;
    t.output_axis = layouts[i].output;
    t.min_mm = min_mm;
    t.step_mm = step_mm;
    for (int k = 0; k < points; ++k) {
      const double p = min_mm + step_mm * k;
      double e = 0.0;
      switch (i) {
        case 0:
          e = id.scale_mismatch * p + screw(m.y_screw_lead_mm, id.y_screw_sin_mm, id.y_screw_cos_mm, p);
          break;
        case 1:
          e = screw(m.z_screw_lead_mm, id.z_screw_sin_mm, id.z_screw_cos_mm, p);
          break;
        case 2:
          e = id.squareness * p + id.y_straightness_per_mm * p * p;
          break;
        default:
          e = id.z_straightness_per_mm * p * p;
      }
      if (!in_force.empty()) e += in_force[i].error_mm[static_cast<std::size_t>(k)];
      t.error_mm.push_back(e);
    }
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace gaugeloop

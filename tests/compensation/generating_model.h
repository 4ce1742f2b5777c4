// Test-side model of a worm-wheel generating grinder, written apart from the product's closed
// forms (compensation/gear_coupling.h): the worm's thread and the gear's tooth space as 3D
// helices, the setting angle found by root finding where their tangents are parallel at the
// grinding point, the worm's lead found from its normal pitch, and C(Y, Z, B) solved from the
// mesh condition in the plane tangent to both pitch cylinders.
#pragma once

#include <array>
#include <cmath>
#include <functional>

#include "core/gear.h"
#include "tests/support/angles.h"

namespace gaugeloop::testing {

using Vec = std::array<double, 3>;
inline Vec add(Vec a, Vec b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline Vec sub(Vec a, Vec b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline Vec scale(Vec a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
inline double dot(Vec a, Vec b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Vec cross(Vec a, Vec b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline Vec unit(Vec a) { return scale(a, 1.0 / std::sqrt(dot(a, a))); }

// A root of f in [lo, hi] where f changes sign, to the last bit.
inline double bisect(const std::function<double(double)>& f, double lo, double hi) {
  double flo = f(lo);
  for (int i = 0; i < 200 && hi - lo > 0.0; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (mid == lo || mid == hi) break;
    const double fm = f(mid);
    if ((fm < 0.0) == (flo < 0.0)) {
      lo = mid;
      flo = fm;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

// The tangent of a curve at parameter u, by a central difference.
inline Vec tangent(const std::function<Vec(double)>& curve, double u) {
  const double h = 1e-6;
  return unit(sub(curve(u + h), curve(u - h)));
}

// The machine of core/gear.h: gear axis +z through the origin, the worm's centre on +x at the
// stroke's height Z, the grinding point T = (r2, 0, Z) where both pitch cylinders touch.
class GeneratingModel {
 public:
  explicit GeneratingModel(const GearPart& p) : p_(p) {
    const double mn = p.gear.normal_module_mm;
    beta_ = p.gear.helix_angle_deg * kRadPerDeg;
    hg_ = p.gear.helix_angle_deg == 0.0 ? 0.0 : (p.gear.hand == Hand::kRight ? 1.0 : -1.0);
    hw_ = p.worm.hand == Hand::kRight ? 1.0 : -1.0;
    r0_ = p.worm.pitch_diameter_mm / 2.0;
    // The gear's pitch radius: its teeth, one normal pitch (pi m_n) apart across the helix.
    r2_ = p.gear.teeth * mn / (2.0 * std::cos(beta_));
    // The worm's lead: the one whose threads are one normal pitch apart on its pitch cylinder.
    // A lead L makes threads L / z0 apart along the axis, and across the thread that times the
    // cosine of the thread's angle to the circumference, atan(L / (2 pi r0)).
    const double z0 = p.worm.starts;
    auto normal_pitch_excess = [&](double lead) {
      const double circumference = 2.0 * kPi * r0_;
      return lead / z0 * circumference / std::sqrt(circumference * circumference + lead * lead) - kPi * mn;
    };
    lead_ = bisect(normal_pitch_excess, 1e-9, 1e6);
    // The setting angle: where the thread's tangent at T is parallel to the tooth's.
    setting_rad_ = bisect(
        [&](double eta) {
          eta_ = eta;
          const double u = thread_at_contact(0.0, 0.0, 0.0);
          const Vec tw = tangent([&](double v) { return thread(v, 0.0, 0.0, 0.0); }, u);
          const Vec tg = tangent([&](double z) { return tooth(z, 0.0); }, 0.0);
          return cross(tw, tg)[0];
        },
        -89.0 * kRadPerDeg, 89.0 * kRadPerDeg);
    eta_ = setting_rad_;
  }

  double setting_angle_deg() const { return setting_rad_ / kRadPerDeg; }
  double lead_mm() const { return lead_; }

  // C (deg) that meshes the gear with the worm standing at B (deg), Y, Z (mm), near C = 0.
  double c_deg(double y_mm, double z_mm, double b_deg) const {
    const double u = thread_at_contact(y_mm, z_mm, b_deg);
    const Vec pw = thread(u, y_mm, z_mm, b_deg);  // the thread where it touches the gear's pitch cylinder's line
    const Vec tg = tangent([&](double z) { return tooth(z, 0.0); }, 0.0);
    const Vec n = unit(cross({1.0, 0.0, 0.0}, tg));  // across the tooth, in the tangent plane
    // The tooth space at the thread's height, developed onto the tangent plane: y = r2 * angle.
    auto miss = [&](double c) {
      const Vec g = tooth(pw[2], c);
      const Vec q{r2_, r2_ * std::atan2(g[1], g[0]), pw[2]};
      return dot(sub(pw, q), n);
    };
    return bisect(miss, -20.0, 20.0);
  }

 private:
  // The worm's axis and its frame: w_x from the worm's centre to T, w_y = a x w_x.
  Vec axis() const { return {0.0, std::cos(eta_), std::sin(eta_)}; }
  Vec centre(double z_mm) const { return {r2_ + r0_, 0.0, z_mm}; }

  // Thread 0 of the worm turned by B and shifted by Y along its axis, at body angle u: in the
  // body, a right-hand thread rises by L / 2 pi per radian about the axis.
  Vec thread(double u, double y_mm, double z_mm, double b_deg) const {
    const Vec a = axis();
    const Vec wx{-1.0, 0.0, 0.0};
    const Vec wy = cross(a, wx);
    const double at = u + b_deg * kRadPerDeg;  // the body turned by B
    Vec p = add(centre(z_mm), scale(a, y_mm + hw_ * lead_ / (2.0 * kPi) * u));
    p = add(p, scale(wx, r0_ * std::cos(at)));
    return add(p, scale(wy, r0_ * std::sin(at)));
  }

  // The body angle at which thread 0 passes the line where the worm's pitch cylinder touches the
  // gear's (the side facing the gear: w_y component 0, w_x component positive).
  double thread_at_contact(double y_mm, double z_mm, double b_deg) const {
    const Vec a = axis();
    const Vec wy = cross(a, {-1.0, 0.0, 0.0});
    const double guess = -b_deg * kRadPerDeg;
    return bisect([&](double u) { return dot(sub(thread(u, y_mm, z_mm, b_deg), centre(z_mm)), wy); }, guess - 1.0,
                  guess + 1.0);
  }

  // Tooth space 0 of the gear turned by C, at height z: a right-hand helix turns +C as z rises.
  Vec tooth(double z_mm, double c_deg) const {
    const double angle = c_deg * kRadPerDeg + hg_ * z_mm * std::tan(beta_) / r2_;
    return {r2_ * std::cos(angle), r2_ * std::sin(angle), z_mm};
  }

  GearPart p_;
  double beta_ = 0.0, hg_ = 0.0, hw_ = 0.0, r0_ = 0.0, r2_ = 0.0, lead_ = 0.0;
  double setting_rad_ = 0.0;
  mutable double eta_ = 0.0;
};

// The factors as finite differences of the model's C(Y, Z, B). The relation is linear, so a
// step of 1 mm or 1 deg loses nothing; central differences cancel the constant.
struct NumericFactors {
  double s_yc, s_zc, s_bc;
};
inline NumericFactors numeric_factors(const GeneratingModel& m) {
  const double h = 1.0;
  return {(m.c_deg(h, 0, 0) - m.c_deg(-h, 0, 0)) / (2 * h), (m.c_deg(0, h, 0) - m.c_deg(0, -h, 0)) / (2 * h),
          (m.c_deg(0, 0, h) - m.c_deg(0, 0, -h)) / (2 * h)};
}

}  // namespace gaugeloop::testing

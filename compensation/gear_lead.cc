// Lead traces: ISO 1328-1 figures and the mesh error identified from them.
#include "compensation/gear_lead.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "core/angles.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

// A trace's checks; `what` and `position` name it in messages ("lead", "Z"; "profile", "roll length").
Status check_trace(const LeadTrace& t, const char* what = "lead", const char* position = "Z") {
  const std::string which =
      std::string(what) + " trace of gap " + std::to_string(t.gap) + ", " + std::string(flank_name(t.flank)) + " flank";
  if (t.z_mm.size() != t.deviation_um.size()) {
    return make_error(ErrorCode::kInvalidInput, which + ": " + std::to_string(t.z_mm.size()) + " positions but " +
                                                    std::to_string(t.deviation_um.size()) + " deviations");
  }
  for (std::size_t i = 0; i < t.z_mm.size(); ++i) {
    if (!std::isfinite(t.z_mm[i]) || !std::isfinite(t.deviation_um[i])) {
      return make_error(ErrorCode::kInvalidInput, which + ": point " + std::to_string(i + 1) + " is not finite");
    }
    if (i > 0 && !(t.z_mm[i] > t.z_mm[i - 1])) {
      return make_error(ErrorCode::kInvalidInput, which + ": " + position + " " + format_fixed(t.z_mm[i], 3) +
                                                      " mm does not increase (point " + std::to_string(i + 1) + ")");
    }
  }
  return {};
}

}  // namespace

double base_radius_mm(const GearGeometry& g) {
  const double beta = g.helix_angle_deg * kRadPerDeg;
  const double alpha_t = std::atan(std::tan(g.pressure_angle_deg * kRadPerDeg) / std::cos(beta));
  return g.teeth * g.normal_module_mm / std::cos(beta) / 2.0 * std::cos(alpha_t);
}

namespace {

// The figures of the points of (x, d) in [from, to]: the band, the band about the least-squares
// line, that line's rise over the range. kInvalidInput naming the trace for fewer than 3 points.
Result<FlankLineFigures> figures_over(const char* what, int gap, Flank flank, const std::vector<double>& xs,
                                      const std::vector<double>& ds, double from, double to) {
  std::vector<double> x, d;
  for (std::size_t i = 0; i < xs.size(); ++i) {
    if (xs[i] >= from - 1e-9 && xs[i] <= to + 1e-9) {
      x.push_back(xs[i]);
      d.push_back(ds[i]);
    }
  }
  FlankLineFigures f;
  f.from_mm = from;
  f.to_mm = to;
  f.points = static_cast<int>(x.size());
  if (x.size() < 3) {
    return make_error(ErrorCode::kInvalidInput, std::string(what) + " trace of gap " + std::to_string(gap) + ", " +
                                                    std::string(flank_name(flank)) +
                                                    " flank: " + std::to_string(x.size()) +
                                                    " points in the evaluation range " + format_fixed(from, 2) +
                                                    " .. " + format_fixed(to, 2) + " mm; at least 3 are needed");
  }
  // The design line of an unmodified flank has the trace's nominal direction: deviation 0.
  const auto [lo, hi] = std::minmax_element(d.begin(), d.end());
  f.total_um = *hi - *lo;
  const double n = static_cast<double>(x.size());
  double sx = 0.0, sd = 0.0, sxx = 0.0, sxd = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sx += x[i];
    sd += d[i];
    sxx += x[i] * x[i];
    sxd += x[i] * d[i];
  }
  const double slope = (n * sxd - sx * sd) / (n * sxx - sx * sx);
  const double intercept = (sd - slope * sx) / n;
  double rmin = 0.0, rmax = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double r = d[i] - (intercept + slope * x[i]);
    rmin = std::min(rmin, r);
    rmax = std::max(rmax, r);
  }
  f.form_um = rmax - rmin;
  f.slope_um = slope * (to - from);
  return f;
}

}  // namespace

Result<LeadFigures> lead_figures(const LeadTrace& t, const GearGeometry& g) {
  if (Status c = check_trace(t); !c) return c.error();
  const double b = g.face_width_mm;
  const double trim = std::min(0.05 * b, g.normal_module_mm);
  return figures_over("lead", t.gap, t.flank, t.z_mm, t.deviation_um, -b / 2.0 + trim, b / 2.0 - trim);
}

ProfileRange profile_range(const GearGeometry& g) {
  const double r_b = base_radius_mm(g);
  const double r_p = g.teeth * g.normal_module_mm / std::cos(g.helix_angle_deg * kRadPerDeg) / 2.0;
  auto roll = [&](double r) { return r > r_b ? std::sqrt(r * r - r_b * r_b) : 0.0; };
  ProfileRange p;
  p.start_roll_mm = roll(r_p - g.normal_module_mm);
  p.tip_roll_mm = roll(r_p + g.normal_module_mm);
  p.evaluation_end_roll_mm = p.start_roll_mm + 0.92 * (p.tip_roll_mm - p.start_roll_mm);
  return p;
}

Result<ProfileFigures> profile_figures(const ProfileTrace& t, const GearGeometry& g) {
  if (Status c = check_trace(LeadTrace{t.gap, t.flank, t.roll_mm, t.deviation_um}, "profile", "roll length"); !c) {
    return c.error();
  }
  const ProfileRange r = profile_range(g);
  return figures_over("profile", t.gap, t.flank, t.roll_mm, t.deviation_um, r.start_roll_mm, r.evaluation_end_roll_mm);
}

double helix_tolerance_um(int tolerance_class, double d, double b) {
  return (0.1 * std::sqrt(d) + 0.63 * std::sqrt(b) + 4.2) * std::pow(std::sqrt(2.0), tolerance_class - 5);
}

namespace {

// The smallest class 1..11 whose tolerance holds `total_um`; 12 when none does.
template <typename Tolerance>
int smallest_class(double total_um, Tolerance tolerance_um) {
  for (int a = 1; a <= 11; ++a) {
    if (total_um <= tolerance_um(a)) return a;
  }
  return 12;
}

}  // namespace

int helix_tolerance_class(double total_um, double d, double b) {
  return smallest_class(total_um, [&](int a) { return helix_tolerance_um(a, d, b); });
}

double profile_tolerance_um(int tolerance_class, double m_n, double d) {
  return (3.2 * std::sqrt(m_n) + 0.22 * std::sqrt(d) + 0.7) * std::pow(std::sqrt(2.0), tolerance_class - 5);
}

int profile_tolerance_class(double total_um, double m_n, double d) {
  return smallest_class(total_um, [&](int a) { return profile_tolerance_um(a, m_n, d); });
}

Result<MeshIdentification> identify_mesh_error(const std::vector<LeadTrace>& traces,
                                               const std::vector<double>& spline_z, double r_b) {
  if (traces.empty()) return make_error(ErrorCode::kInvalidInput, "no lead trace to identify the mesh error from");
  if (spline_z.size() < 2) return make_error(ErrorCode::kInvalidInput, "the stroke needs at least 2 spline points");
  for (const LeadTrace& t : traces) {
    if (Status c = check_trace(t); !c) return c.error();
  }
  const std::size_t k_count = spline_z.size();
  // The span of spline point k: its hat function N_k, 1 at z_k, 0 at its neighbours.
  auto hat = [&](std::size_t k, double z) {
    if (k > 0 && z >= spline_z[k - 1] && z <= spline_z[k])
      return (z - spline_z[k - 1]) / (spline_z[k] - spline_z[k - 1]);
    if (k + 1 < k_count && z >= spline_z[k] && z <= spline_z[k + 1]) {
      return (spline_z[k + 1] - z) / (spline_z[k + 1] - spline_z[k]);
    }
    return 0.0;
  };
  // Which spline points the traces see.
  MeshIdentification m;
  m.z_mm = spline_z;
  m.observed.assign(k_count, false);
  for (const LeadTrace& t : traces) {
    bool on_stroke = false;
    for (double z : t.z_mm) {
      if (z < spline_z.front() || z > spline_z.back()) continue;
      on_stroke = true;
      for (std::size_t k = 0; k < k_count; ++k) m.observed[k] = m.observed[k] || hat(k, z) > 1e-12;
    }
    if (!on_stroke) {
      return make_error(ErrorCode::kInvalidInput,
                        "lead trace of gap " + std::to_string(t.gap) + ", " + std::string(flank_name(t.flank)) +
                            " flank: no point on the stroke (Z " + format_fixed(spline_z.front(), 3) + " .. " +
                            format_fixed(spline_z.back(), 3) + " mm)");
    }
  }
  std::vector<int> column(k_count, -1);
  int columns = 0;
  for (std::size_t k = 0; k < k_count; ++k) {
    if (m.observed[k]) column[k] = columns++;
  }
  const int observed_count = columns;
  columns += static_cast<int>(traces.size());
  int rows = 0;
  for (const LeadTrace& t : traces) {
    for (double z : t.z_mm) rows += (z >= spline_z.front() && z <= spline_z.back()) ? 1 : 0;
  }
  // deviation_um = sign r_b 1000 rad(mesh) + offset_t, mesh in degrees.
  const double um_per_deg = r_b * 1000.0 * kRadPerDeg;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, columns);
  Eigen::VectorXd y(rows);
  int row = 0;
  for (std::size_t ti = 0; ti < traces.size(); ++ti) {
    const LeadTrace& t = traces[ti];
    for (std::size_t i = 0; i < t.z_mm.size(); ++i) {
      const double z = t.z_mm[i];
      if (z < spline_z.front() || z > spline_z.back()) continue;
      for (std::size_t k = 0; k < k_count; ++k) {
        const double w = hat(k, z);
        if (w > 0.0) a(row, column[k]) += flank_sign(t.flank) * um_per_deg * w;
      }
      a(row, observed_count + static_cast<int>(ti)) = 1.0;
      y(row) = t.deviation_um[i];
      ++row;
    }
  }
  // Rank-deficient by design (the mean mesh error and the offsets trade off): the minimum-norm
  // least-squares solution, then the mean moved out of the mesh error, which leaves the fit as it is.
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(a);
  const Eigen::VectorXd x = cod.solve(y);
  m.rank = static_cast<int>(cod.rank());
  m.unknowns = columns;
  m.traces = static_cast<int>(traces.size());
  m.samples = rows;
  const Eigen::VectorXd r = a * x - y;
  m.residual_rms_um = rows > 0 ? std::sqrt(r.squaredNorm() / rows) : 0.0;
  double mean = 0.0;
  for (int c = 0; c < observed_count; ++c) mean += x(c);
  mean /= std::max(1, observed_count);
  m.mesh_deg.assign(k_count, 0.0);
  for (std::size_t k = 0; k < k_count; ++k) {
    if (column[k] >= 0) m.mesh_deg[k] = x(column[k]) - mean;
  }
  // Points beyond the traces: held at the nearest observed one, so SIM1 does not jump there.
  for (std::size_t k = 0; k < k_count; ++k) {
    if (m.observed[k]) continue;
    std::size_t best = k_count;
    for (std::size_t j = 0; j < k_count; ++j) {
      if (m.observed[j] &&
          (best == k_count || std::abs(spline_z[j] - spline_z[k]) < std::abs(spline_z[best] - spline_z[k]))) {
        best = j;
      }
    }
    if (best < k_count) m.mesh_deg[k] = m.mesh_deg[best];
  }
  return m;
}

}  // namespace gaugeloop

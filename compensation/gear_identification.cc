// The axes' errors identified from the lead and a ballbar, with what the data cannot separate.
#include "compensation/gear_identification.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cctype>
#include <cmath>

#include "compensation/least_squares.h"
#include "core/angles.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

// The value of one basis function of `t` at z: 0 the term (or its sine), 1 its cosine.
double basis(const ErrorTerm& t, int part, double z) {
  switch (t.kind) {
    case ErrorTermKind::kLinear:
      return z;
    case ErrorTermKind::kBow:
      return z * z;
    case ErrorTermKind::kPeriodic: {
      const double x = 2.0 * kPi * z / t.pitch_mm;
      return part == 0 ? std::sin(x) : std::cos(x);
    }
  }
  return 0.0;
}

int parts_of(const ErrorTerm& t) { return t.kind == ErrorTermKind::kPeriodic ? 2 : 1; }

// Degrees of C per unit of the axis' error, through the gearbox: how dSIM weighs it.
double dsim_factor(const GearCoupling& k, char axis) {
  switch (axis) {
    case 'Y':
      return k.s_yc_deg_per_mm;
    case 'Z':
      return k.s_zc_deg_per_mm;
    case 'B':
      return k.s_bc;
    default:
      return -1.0;  // C
  }
}

// SIM1 at z: linear between the spline points, held beyond them.
double sim_at(const std::vector<StrokeSimPoint>& s, double z) {
  if (s.empty()) return 0.0;
  if (z <= s.front().z_mm) return s.front().sim_deg;
  if (z >= s.back().z_mm) return s.back().sim_deg;
  std::size_t i = 1;
  while (s[i].z_mm < z) ++i;
  const double t = (z - s[i - 1].z_mm) / (s[i].z_mm - s[i - 1].z_mm);
  return s[i - 1].sim_deg + t * (s[i].sim_deg - s[i - 1].sim_deg);
}

}  // namespace

std::string ErrorTerm::name() const {
  const std::string a(1, axis);
  switch (kind) {
    case ErrorTermKind::kLinear:
      return a + " linear";
    case ErrorTermKind::kBow:
      return a + " bow";
    case ErrorTermKind::kPeriodic:
      return a + " periodic " + format_fixed(pitch_mm, pitch_mm == std::round(pitch_mm) ? 0 : 3) + " mm";
  }
  return a;
}

Result<std::vector<ErrorTerm>> parse_error_terms(std::string_view text) {
  std::vector<ErrorTerm> out;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = text.find(',', pos);
    std::string item(text.substr(pos, comma == std::string_view::npos ? std::string_view::npos : comma - pos));
    pos = comma == std::string_view::npos ? text.size() + 1 : comma + 1;
    item.erase(std::remove(item.begin(), item.end(), ' '), item.end());
    if (item.empty()) continue;
    auto fail = [&item](const std::string& why) {
      return make_error(ErrorCode::kInvalidInput,
                        "error term `" + item + "`: " + why +
                            "; a term is <axis>:<kind>, axis y, z, b or c, kind linear, bow or periodic@<pitch mm>");
    };
    const std::size_t colon = item.find(':');
    if (colon != 1) return fail("no axis");
    ErrorTerm t;
    t.axis = static_cast<char>(std::toupper(static_cast<unsigned char>(item[0])));
    if (std::string("YZBC").find(t.axis) == std::string::npos) return fail("unknown axis");
    const std::string kind = item.substr(2);
    if (kind == "linear") {
      t.kind = ErrorTermKind::kLinear;
    } else if (kind == "bow") {
      t.kind = ErrorTermKind::kBow;
    } else if (kind.rfind("periodic@", 0) == 0) {
      t.kind = ErrorTermKind::kPeriodic;
      char* end = nullptr;
      const std::string pitch = kind.substr(9);
      t.pitch_mm = std::strtod(pitch.c_str(), &end);
      if (pitch.empty() || end != pitch.c_str() + pitch.size() || !(t.pitch_mm > 0.0) || !std::isfinite(t.pitch_mm)) {
        return fail("the pitch must be a positive number of mm");
      }
    } else {
      return fail("unknown kind");
    }
    out.push_back(t);
  }
  if (out.empty()) return make_error(ErrorCode::kInvalidInput, "no error term given (e.g. y:bow,z:periodic@12)");
  return out;
}

AxisErrors AxisIdentification::at(double z) const {
  AxisErrors e;
  for (const IdentifiedTerm& t : terms) {
    double v = t.sin_coefficient * basis(t.term, 0, z);
    if (t.term.kind == ErrorTermKind::kPeriodic) v += t.cos_coefficient * basis(t.term, 1, z);
    switch (t.term.axis) {
      case 'Y':
        e.y_mm += v;
        break;
      case 'Z':
        e.z_mm += v;
        break;
      case 'B':
        e.b_deg += v;
        break;
      default:
        e.c_deg += v;
    }
  }
  return e;
}

Result<AxisIdentification> identify_axis_errors(const GearCoupling& k, double r_b, const std::vector<ErrorTerm>& terms,
                                                const std::vector<LeadTrace>& traces,
                                                const std::vector<StrokeSimPoint>& sim_in_force,
                                                const BallbarCircle* ballbar) {
  if (terms.empty()) return make_error(ErrorCode::kInvalidInput, "no error term to fit");
  if (traces.empty()) return make_error(ErrorCode::kInvalidInput, "no lead trace to fit the error terms to");
  for (std::size_t i = 0; i < terms.size(); ++i) {
    if (terms[i].kind == ErrorTermKind::kPeriodic && !(terms[i].pitch_mm > 0.0)) {
      return make_error(ErrorCode::kInvalidInput, terms[i].name() + ": the pitch must be positive");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (terms[j].name() == terms[i].name()) {
        return make_error(ErrorCode::kInvalidInput, "error term " + terms[i].name() + " is given twice");
      }
    }
  }
  if (ballbar != nullptr && (ballbar->angle_deg.size() != ballbar->radial_um.size() || ballbar->angle_deg.size() < 8 ||
                             !(ballbar->radius_mm > 0.0))) {
    return make_error(ErrorCode::kInvalidInput,
                      "the ballbar circle needs at least 8 points, each an angle and a "
                      "radial error, and a positive radius");
  }
  // Columns: the terms' (a periodic term two), one offset per trace, and with a ballbar its
  // centring in Y and Z and Y's scale.
  std::vector<int> first_column;
  int columns = 0;
  for (const ErrorTerm& t : terms) {
    first_column.push_back(columns);
    columns += parts_of(t);
  }
  const int offset_column = columns;
  columns += static_cast<int>(traces.size());
  const int ballbar_column = columns;
  if (ballbar != nullptr) columns += 3;
  int lead_rows = 0;
  for (const LeadTrace& t : traces) lead_rows += static_cast<int>(t.z_mm.size());
  const int ballbar_rows = ballbar != nullptr ? static_cast<int>(ballbar->angle_deg.size()) : 0;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(lead_rows + ballbar_rows, columns);
  Eigen::VectorXd y(lead_rows + ballbar_rows);
  const double um_per_deg = r_b * 1000.0 * kPi / 180.0;
  int row = 0;
  for (std::size_t ti = 0; ti < traces.size(); ++ti) {
    const LeadTrace& t = traces[ti];
    const double s = flank_sign(t.flank) * um_per_deg;
    for (std::size_t i = 0; i < t.z_mm.size(); ++i) {
      const double z = t.z_mm[i];
      // deviation = s (SIM1 - dSIM) + offset, dSIM = sum of factor x term.
      for (std::size_t j = 0; j < terms.size(); ++j) {
        for (int p = 0; p < parts_of(terms[j]); ++p) {
          a(row, first_column[j] + p) = -s * dsim_factor(k, terms[j].axis) * basis(terms[j], p, z);
        }
      }
      a(row, offset_column + static_cast<int>(ti)) = 1.0;
      y(row) = t.deviation_um[i] - s * sim_at(sim_in_force, z);
      ++row;
    }
  }
  for (int i = 0; i < ballbar_rows; ++i) {
    const double ang = ballbar->angle_deg[static_cast<std::size_t>(i)] * kPi / 180.0;
    const double z = ballbar->radius_mm * std::sin(ang);
    for (std::size_t j = 0; j < terms.size(); ++j) {
      const double w = terms[j].axis == 'Y' ? std::cos(ang) : terms[j].axis == 'Z' ? std::sin(ang) : 0.0;
      for (int p = 0; p < parts_of(terms[j]); ++p) a(row, first_column[j] + p) = 1000.0 * w * basis(terms[j], p, z);
    }
    a(row, ballbar_column) = std::cos(ang);
    a(row, ballbar_column + 1) = std::sin(ang);
    a(row, ballbar_column + 2) = ballbar->radius_mm * std::cos(ang) * std::cos(ang);
    y(row) = ballbar->radial_um[static_cast<std::size_t>(i)];
    ++row;
  }
  // Scaled to unit columns, the singular values say what the data can tell apart.
  const ScaledFit fit = scaled_least_squares(a, y);
  std::vector<std::vector<std::string>> groups;
  for (const Eigen::VectorXd& v : fit.null_directions) {
    std::vector<std::string> group;
    for (std::size_t j = 0; j < terms.size(); ++j) {
      double weight = 0.0;
      for (int p = 0; p < parts_of(terms[j]); ++p) weight = std::max(weight, std::abs(v(first_column[j] + p)));
      if (weight > 1e-6 && std::find(group.begin(), group.end(), terms[j].name()) == group.end()) {
        group.push_back(terms[j].name());
      }
    }
    if (!group.empty()) groups.push_back(group);
  }
  // A column with nothing in it (a term of an axis no data sees) is its own group.
  for (std::size_t j = 0; j < terms.size(); ++j) {
    if (a.col(first_column[j]).norm() == 0.0) {
      bool named = false;
      for (const auto& g : groups) named = named || std::find(g.begin(), g.end(), terms[j].name()) != g.end();
      if (!named) groups.push_back({terms[j].name()});
    }
  }
  if (!groups.empty()) {
    std::string what;
    for (const auto& g : groups) {
      std::string names;
      for (const std::string& n : g) names += (names.empty() ? "" : " and ") + n;
      what += (what.empty() ? "" : "; ") + (g.size() > 1 ? names + " act alike" : names + " is not seen");
    }
    return make_error(ErrorCode::kRefused,
                      "the data cannot tell these error terms apart: " + what +
                          ". The lead sees the axes only through one sum (dSIM), so terms of the same shape on "
                          "different axes are one term to it; a ballbar circle in ZY tells Y and Z apart, nothing "
                          "here tells B from C. Fit one term of each group" +
                          (ballbar == nullptr ? ", or add a ballbar (--ballbar)" : std::string()) +
                          ". Nothing was written");
  }
  const Eigen::VectorXd& x = fit.x;
  const Eigen::VectorXd r = a * x - y;
  AxisIdentification out;
  out.lead_samples = lead_rows;
  out.ballbar_samples = ballbar_rows;
  out.condition = fit.condition;
  out.lead_residual_rms_um = std::sqrt(r.head(lead_rows).squaredNorm() / std::max(1, lead_rows));
  if (ballbar_rows > 0) out.ballbar_residual_rms_um = std::sqrt(r.tail(ballbar_rows).squaredNorm() / ballbar_rows);
  for (std::size_t j = 0; j < terms.size(); ++j) {
    IdentifiedTerm t;
    t.term = terms[j];
    t.sin_coefficient = x(first_column[j]);
    if (terms[j].kind == ErrorTermKind::kPeriodic) {
      t.cos_coefficient = x(first_column[j] + 1);
      t.value = std::hypot(t.sin_coefficient, t.cos_coefficient);
      t.phase_rad = std::atan2(t.cos_coefficient, t.sin_coefficient);
    } else {
      t.value = t.sin_coefficient;
    }
    out.terms.push_back(t);
  }
  return out;
}

}  // namespace gaugeloop

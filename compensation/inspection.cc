// Velocity and acceleration error, dial runout and roundness of the base circle.
#include "compensation/inspection.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <unsupported/Eigen/FFT>

#include "compensation/least_squares.h"
#include "compensation/message_text.h"
#include "compensation/thread_fft.h"
#include "core/angles.h"

namespace gaugeloop {
namespace {

constexpr int kMaxHarmonic = kDegreesPerRevolution / 2 - 1;  // below Nyquist, whose derivative is not defined
constexpr double kUmPerMm = 1000.0;
constexpr int kMinRoundnessDegrees = 3;  // a + b cos + c sin needs three degrees

Status check_finite(const DegreeTable& error_um, const std::string& who) {
  for (size_t d = 0; d < kDegrees; ++d) {
    if (!std::isfinite(error_um[d])) {
      return make_error(ErrorCode::kInvalidInput,
                        who + ": the lift error at cam degree " + std::to_string(d) + " is NaN or infinite");
    }
  }
  return {};
}

Status check_harmonic(int max_harmonic, const std::string& who) {
  if (max_harmonic < 1 || max_harmonic > kMaxHarmonic) {
    return make_error(ErrorCode::kInvalidInput, who + ": max_harmonic " + std::to_string(max_harmonic) +
                                                    "; give 1 to " + std::to_string(kMaxHarmonic));
  }
  return {};
}

// The derivative of the given order, per degree, of the table band-limited to harmonics
// 1..max_harmonic: bin k times (i k w)^order. The real inverse FFT reads bins 0..N/2 only
// (a real table's bin N - k is the conjugate of bin k), so the mirrors are not written.
DegreeTable spectral_derivative(const std::vector<std::complex<double>>& spectrum, int max_harmonic, int order) {
  std::vector<std::complex<double>> d(kDegrees, 0.0);
  const std::complex<double> i_w(0.0, kRadPerDeg);  // w = 2 pi / 360 rad per degree
  for (size_t k = 1; k <= static_cast<size_t>(max_harmonic); ++k) {
    d[k] = spectrum[k] * std::pow(i_w * static_cast<double>(k), order);
  }
  std::vector<double> out;
  thread_fft().inv(out, d);
  DegreeTable table{};
  std::copy(out.begin(), out.end(), table.begin());
  return table;
}

size_t largest_abs(const DegreeTable& values) {
  size_t worst = 0;
  for (size_t d = 1; d < kDegrees; ++d) {
    if (std::abs(values[d]) > std::abs(values[worst])) worst = d;
  }
  return worst;
}

// The base-circle window's degrees, as analyse_lobe selects them; at least three, the fewest a mean and an eccentricity
// leave a residue of.
Result<std::vector<size_t>> window_degrees(const AnalysisSettings& window) {
  Result<std::vector<size_t>> degrees = base_circle_window_degrees(window, "inspection");
  if (!degrees) return degrees.error();
  if (degrees->size() < static_cast<size_t>(kMinRoundnessDegrees)) {
    return make_error(ErrorCode::kInvalidInput,
                      "inspection: the base-circle window " + base_circle_window_text(window) + " holds " +
                          std::to_string(degrees->size()) +
                          " whole cam degrees, fewer than 3; widen base_circle_half_width_deg");
  }
  return degrees;
}

double peak_to_valley(const std::vector<double>& values) {
  const auto [low, high] = std::minmax_element(values.begin(), values.end());
  return *high - *low;
}

// The error over the window less its least-squares a + b cos(theta) + c sin(theta).
std::vector<double> without_eccentricity(const DegreeTable& error_um, const std::vector<size_t>& degrees) {
  const auto n = static_cast<Eigen::Index>(degrees.size());
  Eigen::MatrixXd basis(n, 3);
  Eigen::VectorXd values(n);
  for (Eigen::Index r = 0; r < n; ++r) {
    const double theta = static_cast<double>(degrees[static_cast<size_t>(r)]) * kRadPerDeg;
    basis.row(r) << 1.0, std::cos(theta), std::sin(theta);
    values(r) = error_um[degrees[static_cast<size_t>(r)]];
  }
  // QR with pivoting: a short arc makes cos and sin nearly collinear with the constant.
  const Eigen::VectorXd fit = least_squares(basis, values);
  const Eigen::VectorXd residual = values - basis * fit;
  return {residual.data(), residual.data() + n};
}

}  // namespace

Result<ErrorDerivatives> error_derivatives(const DegreeTable& error_um, const InspectionSettings& settings) {
  if (Status s = check_finite(error_um, "velocity error"); !s.ok()) return s.error();
  if (Status s = check_harmonic(settings.max_harmonic, "velocity error"); !s.ok()) return s.error();
  const std::vector<double> in(error_um.begin(), error_um.end());
  std::vector<std::complex<double>> spectrum;
  thread_fft().fwd(spectrum, in);
  for (std::complex<double>& bin : spectrum) bin /= kUmPerMm;
  ErrorDerivatives out;
  out.velocity_error_mm_per_deg = spectral_derivative(spectrum, settings.max_harmonic, 1);
  out.acceleration_error_mm_per_deg2 = spectral_derivative(spectrum, settings.max_harmonic, 2);
  const size_t v = largest_abs(out.velocity_error_mm_per_deg);
  const size_t a = largest_abs(out.acceleration_error_mm_per_deg2);
  out.max_abs_velocity_error_mm_per_deg = std::abs(out.velocity_error_mm_per_deg[v]);
  out.max_velocity_error_deg = static_cast<int>(v);
  out.max_abs_acceleration_error_mm_per_deg2 = std::abs(out.acceleration_error_mm_per_deg2[a]);
  out.max_acceleration_error_deg = static_cast<int>(a);
  return out;
}

Result<double> derivative_noise_rms(double gauge_noise_um, int revolutions, int order,
                                    const InspectionSettings& settings) {
  if (!std::isfinite(gauge_noise_um) || gauge_noise_um < 0.0 || revolutions < 1 || (order != 1 && order != 2)) {
    return make_error(ErrorCode::kInvalidInput, "derivative noise: gauge noise " + format_fixed(gauge_noise_um, 3) +
                                                    " um, " + std::to_string(revolutions) + " revolutions, order " +
                                                    std::to_string(order) +
                                                    "; give a finite noise >= 0, 1 or more revolutions, order 1 or 2");
  }
  if (Status s = check_harmonic(settings.max_harmonic, "derivative noise"); !s.ok()) return s.error();
  const double s_mm = gauge_noise_um / kUmPerMm / std::sqrt(static_cast<double>(revolutions));
  double gain = 0.0;  // sum of (k w)^(2 order) over the kept harmonics
  for (int k = 1; k <= settings.max_harmonic; ++k) gain += std::pow(k * kRadPerDeg, 2 * order);
  return s_mm * std::sqrt(2.0 * gain / static_cast<double>(kDegrees));
}

Result<BaseCircleInspection> inspect_base_circle(const DegreeTable& error_um, const AnalysisSettings& window) {
  if (Status s = check_finite(error_um, "base-circle inspection"); !s.ok()) return s.error();
  Result<std::vector<size_t>> degrees = window_degrees(window);
  if (!degrees.ok()) return degrees.error();
  std::vector<double> values;
  values.reserve(degrees->size());
  for (size_t d : *degrees) values.push_back(error_um[d]);
  BaseCircleInspection out;
  out.dial_runout_um = peak_to_valley(values);
  out.roundness_um = peak_to_valley(without_eccentricity(error_um, *degrees));
  out.degrees_used = static_cast<int>(degrees->size());
  return out;
}

}  // namespace gaugeloop

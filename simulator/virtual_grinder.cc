// The virtual grinder: commanded path -> machine errors -> envelope of the wheel.
#include "simulator/virtual_grinder.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <fstream>
#include <numbers>
#include <sstream>
#include <unsupported/Eigen/FFT>

#include "compensation/flat_probe.h"
#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"
#include "simulator/seeded_random.h"

namespace gaugeloop {
namespace {

constexpr double kGridStepDeg = 0.1;
constexpr int kGridRows = 3600;

using seeded::mix;
using seeded::unit_uniform;

double deg_to_rad(double deg) { return deg * std::numbers::pi / 180.0; }

// The followed path of a linear axis with the servo's transfer function, in periodic steady
// state: each harmonic k of the turn is multiplied by H(i k w_turn).
std::vector<double> servo_response(const std::vector<double>& commanded_mm, const MachineErrorModel& m) {
  if (m.servo_bandwidth_hz == 0.0) return commanded_mm;
  const auto n = static_cast<int>(commanded_mm.size());
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, commanded_mm);
  const double w = 2.0 * std::numbers::pi * m.servo_bandwidth_hz;
  const double w_turn = 2.0 * std::numbers::pi * m.work_speed_rpm / 60.0;  // rad/s of the first harmonic
  for (int bin = 0; bin < n; ++bin) {
    const int k = bin <= n / 2 ? bin : bin - n;
    const std::complex<double> s(0.0, k * w_turn);
    const std::complex<double> h = (w * w + 2.0 * m.servo_damping * w * m.velocity_feed_forward * s) /
                                   (s * s + 2.0 * m.servo_damping * w * s + w * w);
    spectrum[static_cast<size_t>(bin)] *= h;
  }
  std::vector<double> followed;
  fft.inv(followed, spectrum);
  return followed;
}

// The vibration of one part, um, on the C grid: harmonics with Rayleigh amplitudes and uniform
// phases, scaled to the RMS asked for.
std::vector<double> vibration_um(const MachineErrorModel& m, int part_index) {
  std::vector<double> v(kGridRows, 0.0);
  if (m.vibration_rms_um == 0.0) return v;
  const std::uint64_t part_seed = mix(m.seed ^ mix(0x7669627261ULL + static_cast<std::uint64_t>(part_index)));
  for (int k = m.vibration_min_harmonic; k <= m.vibration_max_harmonic; ++k) {
    const auto key = static_cast<std::uint64_t>(k);
    const double amplitude = std::sqrt(-2.0 * std::log(unit_uniform(mix(part_seed ^ (2 * key)))));
    const double phase = 2.0 * std::numbers::pi * unit_uniform(mix(part_seed ^ (2 * key + 1)));
    for (int j = 0; j < kGridRows; ++j) {
      v[static_cast<size_t>(j)] += amplitude * std::cos(k * deg_to_rad(j * kGridStepDeg) + phase);
    }
  }
  double sum_sq = 0.0;
  for (double x : v) sum_sq += x * x;
  const double rms = std::sqrt(sum_sq / kGridRows);
  for (double& x : v) x *= m.vibration_rms_um / rms;
  return v;
}

Status in_range(double value, double lo, double hi, const char* name, const char* unit) {
  if (std::isfinite(value) && value >= lo && value <= hi) return {};
  std::ostringstream msg;
  msg << "machine error model: " << name << " " << value << " is outside [" << lo << ", " << hi << "]" << unit;
  return make_error(ErrorCode::kInvalidInput, msg.str());
}

}  // namespace

Status validate(const MachineErrorModel& m) {
  for (const Status& s : {in_range(m.work_speed_rpm, 1.0, 1000.0, "work_speed_rpm", " rpm"),
                          in_range(m.servo_bandwidth_hz, 0.0, 1000.0, "servo_bandwidth_hz", " Hz"),
                          in_range(m.servo_damping, 0.05, 5.0, "servo_damping", ""),
                          in_range(m.velocity_feed_forward, 0.0, 1.0, "velocity_feed_forward", ""),
                          in_range(m.geometric_once_um, 0.0, 1000.0, "geometric_once_um", " um"),
                          in_range(m.geometric_twice_um, 0.0, 1000.0, "geometric_twice_um", " um"),
                          in_range(m.geometric_once_phase_deg, -360.0, 360.0, "geometric_once_phase_deg", " deg"),
                          in_range(m.geometric_twice_phase_deg, -360.0, 360.0, "geometric_twice_phase_deg", " deg"),
                          in_range(m.drift_um_per_part, -100.0, 100.0, "drift_um_per_part", " um"),
                          in_range(m.vibration_rms_um, 0.0, 100.0, "vibration_rms_um", " um")}) {
    if (!s) return s;
  }
  if (m.vibration_min_harmonic < 1 || m.vibration_max_harmonic > kGridRows / 2 - 1 ||
      m.vibration_min_harmonic > m.vibration_max_harmonic) {
    return make_error(ErrorCode::kInvalidInput,
                      "machine error model: vibration harmonics " + std::to_string(m.vibration_min_harmonic) + ".." +
                          std::to_string(m.vibration_max_harmonic) +
                          " must satisfy 1 <= min <= max <= " + std::to_string(kGridRows / 2 - 1));
  }
  return {};
}

MachineErrorModel vibration_only(const MachineErrorModel& model) {
  MachineErrorModel m = model;
  m.servo_bandwidth_hz = 0.0;
  m.geometric_once_um = 0.0;
  m.geometric_twice_um = 0.0;
  m.drift_um_per_part = 0.0;
  return m;
}

Result<CommandedPath> commanded_path_from_program(const std::filesystem::path& nc_file) {
  std::ifstream in(nc_file, std::ios::binary);
  if (!in) {
    return make_error(ErrorCode::kNotFound,
                      "virtual grinder: NC program " + nc_file.string() + " cannot be read; push a table first");
  }
  std::ostringstream text;
  text << in.rdbuf();
  Result<ParsedTable> table = parse_table_program(text.str(), nc_file.string());
  if (!table) return table.error();
  Result<TableInterpolant> nc = TableInterpolant::of(table->points, table->interpolation);
  if (!nc) return nc.error();
  CommandedPath path;
  path.c_step_deg = kGridStepDeg;
  path.source = nc_file.string();
  path.x_mm.resize(kGridRows);
  for (int k = 0; k < kGridRows; ++k) path.x_mm[static_cast<size_t>(k)] = nc->at(k * kGridStepDeg).x_mm;
  return path;
}

Result<CommandedPath> commanded_path_from_design(const Part& part, const LiftTable& design) {
  Result<PeriodicSpline> lift = PeriodicSpline::fit(design.angle_deg, design.lift_mm);
  if (!lift) return lift.error();
  Result<MachinePath> exact = compute_machine_path(*lift, part, kGridStepDeg);
  if (!exact) return exact.error();
  return CommandedPath{kGridStepDeg, std::move(exact->x_mm), "design"};
}

Result<GroundPart> grind_part(const Part& part, const CommandedPath& commanded, const MachineErrorModel& m,
                              int part_index) {
  if (Status s = validate(m); !s) return s.error();
  if (commanded.x_mm.size() != static_cast<size_t>(kGridRows) || commanded.c_step_deg != kGridStepDeg) {
    return make_error(ErrorCode::kInvalidInput, "virtual grinder: the commanded path from " + commanded.source +
                                                    " must have 3600 rows at 0.1 deg of C");
  }
  if (part_index < 0) return make_error(ErrorCode::kInvalidInput, "virtual grinder: part index must be >= 0");
  GroundPart ground;
  ground.part_index = part_index;
  ground.followed_x_mm = servo_response(commanded.x_mm, m);
  const double x_max_mm = *std::max_element(commanded.x_mm.begin(), commanded.x_mm.end());
  const std::vector<double> vibration = vibration_um(m, part_index);
  for (int k = 0; k < kGridRows; ++k) {
    const auto j = static_cast<size_t>(k);
    ground.largest_servo_error_um =
        std::max(ground.largest_servo_error_um, std::abs(ground.followed_x_mm[j] - commanded.x_mm[j]) * 1000.0);
    const double c_rad = deg_to_rad(k * kGridStepDeg);
    const double geometric_um = m.geometric_once_um * std::cos(c_rad + deg_to_rad(m.geometric_once_phase_deg)) +
                                m.geometric_twice_um * std::cos(2.0 * c_rad + deg_to_rad(m.geometric_twice_phase_deg));
    const double drift_um = x_max_mm > 0.0 ? m.drift_um_per_part * part_index * commanded.x_mm[j] / x_max_mm : 0.0;
    ground.followed_x_mm[j] += (geometric_um + drift_um + vibration[j]) * 1e-3;
  }
  // Row k of the followed path is the wheel at psi = s * (C - c0) in the cam frame.
  std::vector<std::pair<double, double>> by_psi(kGridRows);
  for (int k = 0; k < kGridRows; ++k) {
    double psi = std::fmod(part.rotation_sense * (k * kGridStepDeg - part.c_offset_deg), 360.0);
    if (psi < 0.0) psi += 360.0;
    if (psi >= 360.0 - 1e-9) psi = 0.0;
    by_psi[static_cast<size_t>(k)] = {psi, ground.followed_x_mm[static_cast<size_t>(k)]};
  }
  std::sort(by_psi.begin(), by_psi.end());
  WheelPath path;
  for (const auto& [psi, x] : by_psi) {
    path.psi_deg.push_back(psi);
    path.x_mm.push_back(x);
  }
  Result<DegreeTable> reading = ground_lobe_reading(path, part);
  if (!reading) return reading.error();
  ground.reading_mm = *reading;
  return ground;
}

TrueLiftError true_lift_error(const DegreeTable& reading_mm, const DegreeTable& design_reading_mm,
                              double base_circle_center_deg, double base_circle_half_width_deg) {
  TrueLiftError e;
  double window_sum = 0.0;
  int window_count = 0;
  const int first = static_cast<int>(std::ceil(base_circle_center_deg - base_circle_half_width_deg));
  const int last = static_cast<int>(std::floor(base_circle_center_deg + base_circle_half_width_deg));
  for (int d = first; d <= last; ++d) {
    const auto i = static_cast<size_t>(((d % 360) + 360) % 360);
    window_sum += (reading_mm[i] - design_reading_mm[i]) * 1000.0;
    ++window_count;
  }
  const double zero_um = window_count > 0 ? window_sum / window_count : 0.0;
  double sum_sq = 0.0;
  for (size_t i = 0; i < e.error_um.size(); ++i) {
    e.error_um[i] = (reading_mm[i] - design_reading_mm[i]) * 1000.0 - zero_um;
    e.max_abs_um = std::max(e.max_abs_um, std::abs(e.error_um[i]));
    sum_sq += e.error_um[i] * e.error_um[i];
  }
  e.rms_um = std::sqrt(sum_sq / static_cast<double>(e.error_um.size()));
  return e;
}

}  // namespace gaugeloop

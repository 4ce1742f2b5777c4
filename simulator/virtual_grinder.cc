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
#include "nc_out/table_layer.h"
#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"
#include "simulator/fine_grid.h"
#include "simulator/seeded_random.h"

namespace gaugeloop {
namespace {

using fine_grid::kFineGridRows;
using fine_grid::kFineGridStepDeg;

using seeded::mix;
using seeded::unit_uniform;

double deg_to_rad(double deg) { return deg * std::numbers::pi / 180.0; }

// The followed path of a linear axis with the servo's transfer function, in periodic steady
// state: each harmonic k of a period of `period_s` seconds, sampled uniformly in time, is
// multiplied by H(i k 2 pi / period_s).
std::vector<double> periodic_response(const std::vector<double>& commanded_mm, double period_s,
                                      const MachineErrorModel& m) {
  const auto n = static_cast<int>(commanded_mm.size());
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, commanded_mm);
  const double w = 2.0 * std::numbers::pi * m.servo_bandwidth_hz;
  const double w_turn = 2.0 * std::numbers::pi / period_s;  // rad/s of the first harmonic
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

// Periodic cubic (Catmull-Rom) interpolation of `y`, sampled at 0, 1, .., n - 1, at position u
// (in samples, any real): exact at the samples, so a grid that falls on them reproduces them.
double periodic_cubic(const std::vector<double>& y, double u) {
  const auto n = static_cast<long>(y.size());
  const double fl = std::floor(u);
  const double f = u - fl;
  const long i = static_cast<long>(fl);
  auto at = [&](long j) { return y[static_cast<size_t>(((j % n) + n) % n)]; };
  const double p0 = at(i - 1), p1 = at(i), p2 = at(i + 1), p3 = at(i + 2);
  return p1 + 0.5 * f * (p2 - p0 + f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)));
}

// The program's C speed at each row of the grid, deg/s, interpolated linearly between its rows.
std::vector<double> omega_on_grid_deg_per_s(const WorkSpeedProgram& p) {
  const auto rows = static_cast<long>(p.speed_rpm.size());
  std::vector<double> w(kFineGridRows);
  for (int k = 0; k < kFineGridRows; ++k) {
    const double u = k * kFineGridStepDeg / p.c_step_deg;
    const double fl = std::floor(u + 1e-9);
    const double f = std::max(0.0, u - fl);
    const long i = static_cast<long>(fl) % rows;
    const double n =
        (1.0 - f) * p.speed_rpm[static_cast<size_t>(i)] + f * p.speed_rpm[static_cast<size_t>((i + 1) % rows)];
    w[static_cast<size_t>(k)] = 6.0 * n;
  }
  return w;
}

// The followed path on the C grid. At a constant speed the C grid is a uniform time grid; under
// a program, X(C) is resampled onto a uniform time grid (the time of each C row from the
// trapezoid rule over dC / omega, inverted piecewise linearly), the response applied there and
// the error brought back to the C rows, both ways by periodic cubics.
std::vector<double> servo_response(const std::vector<double>& commanded_mm, const MachineErrorModel& m) {
  if (m.servo_bandwidth_hz == 0.0) return commanded_mm;
  if (!m.speed_program) return periodic_response(commanded_mm, 60.0 / m.work_speed_rpm, m);
  const std::vector<double> w = omega_on_grid_deg_per_s(*m.speed_program);
  std::vector<double> t(kFineGridRows + 1, 0.0);  // time at each C row, and at the end of the turn
  for (int k = 0; k < kFineGridRows; ++k) {
    const auto j = static_cast<size_t>(k);
    t[j + 1] = t[j] + kFineGridStepDeg * 0.5 * (1.0 / w[j] + 1.0 / w[(j + 1) % kFineGridRows]);
  }
  const double period_s = t[kFineGridRows];
  // Enough time samples that the fastest stretch is sampled about as finely in C as the grid
  // (the slowest to fastest ratio per row, at most 8: beyond that the fast stretch is the base
  // circle, where X barely moves).
  const auto [w_min, w_max] = std::minmax_element(w.begin(), w.end());
  const int per_row = std::clamp(static_cast<int>(std::ceil(*w_max / *w_min - 1e-9)), 1, 8);
  const int samples = kFineGridRows * per_row;
  const double dt = period_s / samples;
  std::vector<double> x_in_time(static_cast<size_t>(samples));
  size_t seg = 0;
  for (int i = 0; i < samples; ++i) {
    const double ti = i * dt;
    while (seg + 1 < static_cast<size_t>(kFineGridRows) && t[seg + 1] <= ti) ++seg;
    const double f = (ti - t[seg]) / (t[seg + 1] - t[seg]);
    x_in_time[static_cast<size_t>(i)] = periodic_cubic(commanded_mm, static_cast<double>(seg) + f);
  }
  const std::vector<double> followed_in_time = periodic_response(x_in_time, period_s, m);
  std::vector<double> error_in_time(x_in_time.size());
  for (size_t i = 0; i < error_in_time.size(); ++i) error_in_time[i] = followed_in_time[i] - x_in_time[i];
  std::vector<double> followed(commanded_mm.size());
  for (int k = 0; k < kFineGridRows; ++k) {
    const auto j = static_cast<size_t>(k);
    followed[j] = commanded_mm[j] + periodic_cubic(error_in_time, t[j] / dt);
  }
  return followed;
}

// The vibration of one part, um, on the C grid: harmonics with Rayleigh amplitudes and uniform
// phases, scaled to the RMS asked for.
std::vector<double> vibration_um(const MachineErrorModel& m, int part_index) {
  std::vector<double> v(kFineGridRows, 0.0);
  if (m.vibration_rms_um == 0.0) return v;
  const std::uint64_t part_seed = mix(m.seed ^ mix(0x7669627261ULL + static_cast<std::uint64_t>(part_index)));
  for (int k = m.vibration_min_harmonic; k <= m.vibration_max_harmonic; ++k) {
    const auto key = static_cast<std::uint64_t>(k);
    const double amplitude = std::sqrt(-2.0 * std::log(unit_uniform(mix(part_seed ^ (2 * key)))));
    const double phase = 2.0 * std::numbers::pi * unit_uniform(mix(part_seed ^ (2 * key + 1)));
    for (int j = 0; j < kFineGridRows; ++j) {
      v[static_cast<size_t>(j)] += amplitude * std::cos(k * deg_to_rad(j * kFineGridStepDeg) + phase);
    }
  }
  double sum_sq = 0.0;
  for (double x : v) sum_sq += x * x;
  const double rms = std::sqrt(sum_sq / kFineGridRows);
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
  if (m.speed_program) {
    const WorkSpeedProgram& p = *m.speed_program;
    const double rows = 360.0 / p.c_step_deg;
    if (!(std::isfinite(rows) && p.c_step_deg > 0.0 && std::abs(rows - std::round(rows)) < 1e-9 &&
          p.speed_rpm.size() == static_cast<size_t>(std::lround(rows)))) {
      return make_error(ErrorCode::kInvalidInput,
                        "machine error model: the work speed program has " + std::to_string(p.speed_rpm.size()) +
                            " speeds at " + std::to_string(p.c_step_deg) +
                            " deg; it needs one speed per step over a turn, the step dividing 360");
    }
    for (size_t k = 0; k < p.speed_rpm.size(); ++k) {
      if (Status s = in_range(p.speed_rpm[k], 1.0, 1000.0, "work speed program speed_rpm", " rpm"); !s) {
        return make_error(ErrorCode::kInvalidInput, s.error().message + " at C " +
                                                        std::to_string(static_cast<double>(k) * p.c_step_deg) + " deg");
      }
    }
  }
  if (m.vibration_min_harmonic < 1 || m.vibration_max_harmonic > kFineGridRows / 2 - 1 ||
      m.vibration_min_harmonic > m.vibration_max_harmonic) {
    return make_error(ErrorCode::kInvalidInput,
                      "machine error model: vibration harmonics " + std::to_string(m.vibration_min_harmonic) + ".." +
                          std::to_string(m.vibration_max_harmonic) +
                          " must satisfy 1 <= min <= max <= " + std::to_string(kFineGridRows / 2 - 1));
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

Result<ProgramSlidePath> slide_path_from_program(const std::filesystem::path& nc_file) {
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
  // A correction layer: the gearbox adds the design table beside it, SIM1 following C 1:1.
  Result<LayerOf> layer = layer_of(*table, nc_file.string());
  if (!layer) return layer.error();
  std::optional<DesignTable> design;
  if (!layer->design_program.empty()) {
    const std::filesystem::path design_file = nc_file.parent_path() / (layer->design_program + ".SPF");
    std::ifstream din(design_file, std::ios::binary);
    if (!din) {
      return make_error(ErrorCode::kNotFound, "virtual grinder: the design table " + design_file.string() +
                                                  " of the correction layer " + nc_file.string() +
                                                  " cannot be read; write the first program from the drawing");
    }
    std::ostringstream design_text;
    design_text << din.rdbuf();
    Result<DesignTable> d = read_design_table(design_text.str(), design_file.string(), layer->design_table_number);
    if (!d) return d.error();
    design = std::move(*d);
  }
  ProgramSlidePath path;
  path.following_axis = table->following_axis;
  path.position_mm.resize(kFineGridRows);
  for (int k = 0; k < kFineGridRows; ++k) {
    const double c = k * kFineGridStepDeg;
    path.position_mm[static_cast<size_t>(k)] = nc->at(c).x_mm + (design ? design->nc.at(c).x_mm : 0.0);
  }
  return path;
}

Result<CommandedPath> commanded_path_from_program(const std::filesystem::path& nc_file) {
  Result<ProgramSlidePath> slide = slide_path_from_program(nc_file);
  if (!slide) return slide.error();
  return CommandedPath{kFineGridStepDeg, std::move(slide->position_mm), nc_file.string()};
}

Result<CommandedPath> commanded_path_from_design(const Part& part, const LiftTable& design) {
  Result<PeriodicSpline> lift = PeriodicSpline::fit(design.angle_deg, design.lift_mm);
  if (!lift) return lift.error();
  Result<MachinePath> exact = compute_machine_path(*lift, part, kFineGridStepDeg);
  if (!exact) return exact.error();
  return CommandedPath{kFineGridStepDeg, std::move(exact->x_mm), "design"};
}

Result<FollowedSlide> follow_slide(const std::vector<double>& commanded_mm, double c_step_deg,
                                   const MachineErrorModel& m, int part_index, std::string_view source) {
  if (Status s = validate(m); !s) return s.error();
  if (commanded_mm.size() != static_cast<size_t>(kFineGridRows) || c_step_deg != kFineGridStepDeg) {
    return make_error(ErrorCode::kInvalidInput, "virtual grinder: the commanded path from " + std::string(source) +
                                                    " must have 3600 rows at 0.1 deg of C");
  }
  if (part_index < 0) return make_error(ErrorCode::kInvalidInput, "virtual grinder: part index must be >= 0");
  FollowedSlide slide;
  slide.followed_mm = servo_response(commanded_mm, m);
  const double max_mm = *std::max_element(commanded_mm.begin(), commanded_mm.end());
  const std::vector<double> vibration = vibration_um(m, part_index);
  for (int k = 0; k < kFineGridRows; ++k) {
    const auto j = static_cast<size_t>(k);
    slide.largest_servo_error_um =
        std::max(slide.largest_servo_error_um, std::abs(slide.followed_mm[j] - commanded_mm[j]) * 1000.0);
    const double c_rad = deg_to_rad(k * kFineGridStepDeg);
    const double geometric_um = m.geometric_once_um * std::cos(c_rad + deg_to_rad(m.geometric_once_phase_deg)) +
                                m.geometric_twice_um * std::cos(2.0 * c_rad + deg_to_rad(m.geometric_twice_phase_deg));
    const double drift_um = max_mm > 0.0 ? m.drift_um_per_part * part_index * commanded_mm[j] / max_mm : 0.0;
    slide.followed_mm[j] += (geometric_um + drift_um + vibration[j]) * 1e-3;
  }
  return slide;
}

Result<GroundPart> grind_part(const Part& part, const CommandedPath& commanded, const MachineErrorModel& m,
                              int part_index) {
  Result<FollowedSlide> slide = follow_slide(commanded.x_mm, commanded.c_step_deg, m, part_index, commanded.source);
  if (!slide) return slide.error();
  GroundPart ground;
  ground.part_index = part_index;
  ground.followed_x_mm = std::move(slide->followed_mm);
  ground.largest_servo_error_um = slide->largest_servo_error_um;
  // Row k of the followed path is the wheel at psi = s * (C - c0) in the cam frame.
  std::vector<std::pair<double, double>> by_psi(kFineGridRows);
  for (int k = 0; k < kFineGridRows; ++k) {
    double psi = std::fmod(part.rotation_sense * (k * kFineGridStepDeg - part.c_offset_deg), 360.0);
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

// The simulated amplifier: lobe model, clock-driven registers and the libmodbus server loop.
#include "simulator/gauge_simulator.h"
#include "simulator/tcp_listener.h"

#include <arpa/inet.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <numbers>
#include <optional>
#include <thread>
#include <vector>

#include "compensation/flat_probe.h"
#include "core/guarded_thread.h"
#include "simulator/seeded_random.h"

namespace gaugeloop {
namespace {

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

using seeded::mix;
using seeded::unit_uniform;

// Standard normal deviate for sample n (Box-Muller on two hashed uniforms).
double gaussian(std::uint64_t seed, std::uint64_t n) {
  const double u1 = unit_uniform(mix(seed * 0x100000001b3ULL ^ (2 * n)));
  const double u2 = unit_uniform(mix(seed * 0x100000001b3ULL ^ (2 * n + 1)));
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

// The status word (bit 0 ready, 1 over-range, 2 under-range, 3 probe missing) as the "ok
// value" register at kStatusCode reports it: 0 ok, bit 3 not ready, the fault bits shifted down.
std::uint16_t status_code(std::uint16_t status) {
  return static_cast<std::uint16_t>(((status >> 1) & 0x7) | ((status & 1) == 0 ? 0x8 : 0));
}

void put_u32(std::uint16_t* regs, int at, std::uint32_t v) {
  regs[at] = static_cast<std::uint16_t>(v >> 16);
  regs[at + 1] = static_cast<std::uint16_t>(v & 0xffff);
}

}  // namespace

namespace {

Status validate_ground_reading(const DegreeTable& reading_mm) {
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    const double v = reading_mm[static_cast<size_t>(d)];
    if (!std::isfinite(v) || std::abs(v) > 1000.0) {
      return make_error(ErrorCode::kInvalidInput, "simulator ground lobe: the reading at cam degree " +
                                                      std::to_string(d) + " is not a lift in [-1000, 1000] mm");
    }
  }
  return {};
}

}  // namespace

Status validate(const SimulatorSettings& s) {
  if (!(s.speed_rpm > 0.0 && s.speed_rpm <= 10000.0)) {
    return make_error(ErrorCode::kInvalidInput, "simulator speed_rpm must be in (0, 10000]");
  }
  if (!(s.time_scale > 0.0 && s.time_scale <= 1000.0)) {
    return make_error(ErrorCode::kInvalidInput, "simulator time_scale must be in (0, 1000]");
  }
  if (!(s.sample_rate_hz >= 100.0 && s.sample_rate_hz <= 1e6)) {
    return make_error(ErrorCode::kInvalidInput, "simulator sample_rate_hz must be in [100, 1e6]");
  }
  if (!(s.lobe_error_peak_um >= 0.0 && s.lobe_error_peak_um <= 1000.0) ||
      !(s.noise_rms_um >= 0.0 && s.noise_rms_um <= 100.0)) {
    return make_error(ErrorCode::kInvalidInput,
                      "simulator lobe error must be in [0, 1000] um and noise in [0, 100] um");
  }
  if (s.ground_reading_mm) {
    if (Status g = validate_ground_reading(*s.ground_reading_mm); !g) return g;
  }
  if (!(s.revolution_lag_deg >= 0.0 && s.revolution_lag_deg < 90.0)) {
    return make_error(ErrorCode::kInvalidInput, "simulator revolution_lag_deg must be in [0, 90)");
  }
  if (s.port < 0 || s.port > 65535) {
    return make_error(ErrorCode::kInvalidInput, "simulator port must be in [0, 65535]");
  }
  return {};
}

GaugeSimulator::GaugeSimulator(const Part& part, const SimulatorSettings& settings, PeriodicSpline lift)
    : part_(part), settings_(settings), lift_(std::move(lift)) {
  if (settings_.ground_reading_mm) {
    ground_ = std::make_shared<const PeriodicSpline>(PeriodicSpline::fit(*settings_.ground_reading_mm));
    return;
  }
  // The form error imitates a ground lobe: servo lag (follows the lift velocity), a nose
  // error (follows the curvature) and a small geometric second harmonic, scaled to the peak.
  for (int i = 0; i < 3600; ++i) {
    const double b = i * 0.1;
    max_d1_ = std::max(max_d1_, std::abs(lift_.d1(b)));
    max_d2_ = std::max(max_d2_, std::abs(lift_.d2(b)));
  }
  double peak = 0.0;
  error_scale_ = 1.0;
  for (int i = 0; i < 3600; ++i) peak = std::max(peak, std::abs(lobe_error_um(i * 0.1)));
  error_scale_ = peak > 0.0 ? settings_.lobe_error_peak_um / peak : 0.0;
}

std::shared_ptr<const PeriodicSpline> GaugeSimulator::ground() const {
  std::lock_guard<std::mutex> lock(ground_mutex_);
  return ground_;
}

Status GaugeSimulator::load_ground_part(const DegreeTable& reading_mm) {
  if (Status s = validate_ground_reading(reading_mm); !s) return s;
  auto next = std::make_shared<const PeriodicSpline>(PeriodicSpline::fit(reading_mm));
  std::lock_guard<std::mutex> lock(ground_mutex_);
  ground_ = std::move(next);
  return {};
}

double GaugeSimulator::lobe_error_um(double cam_angle_deg) const {
  if (const auto g = ground()) return (g->value(cam_angle_deg) - lift_.value(cam_angle_deg)) * 1000.0;
  const double b = cam_angle_deg * std::numbers::pi / 180.0;
  const double shape =
      0.7 * lift_.d1(cam_angle_deg) / max_d1_ - 0.5 * lift_.d2(cam_angle_deg) / max_d2_ + 0.2 * std::cos(2.0 * b + 0.4);
  return error_scale_ * shape;
}

double GaugeSimulator::true_lift_mm(double cam_angle_deg) const { return true_lift_mm(ground().get(), cam_angle_deg); }

double GaugeSimulator::true_lift_mm(const PeriodicSpline* ground, double cam_angle_deg) const {
  if (ground != nullptr) return ground->value(cam_angle_deg);
  return lift_.value(cam_angle_deg) + lobe_error_um(cam_angle_deg) / 1000.0;
}

Result<std::unique_ptr<GaugeSimulator>> GaugeSimulator::start(const Part& part, const LiftTable& design,
                                                              const SimulatorSettings& settings) {
  if (Status s = validate(settings); !s) return s.error();
  Result<PeriodicSpline> design_spline = PeriodicSpline::fit(design.angle_deg, design.lift_mm);
  if (!design_spline) return design_spline.error();
  // The gauge probe is flat: it reads the design lobe's flat-probe lift, not the roller lift.
  std::optional<PeriodicSpline> probe;
  if (part.follower == FollowerKind::kFlat) {
    probe = std::move(*design_spline);
  } else {
    Result<DegreeTable> reading = flat_probe_reading(*design_spline, part);
    if (!reading) return reading.error();
    probe = PeriodicSpline::fit(*reading);
  }
  std::unique_ptr<GaugeSimulator> sim(new GaugeSimulator(part, settings, std::move(*probe)));
  for (const FaultSpec& f : settings.faults) sim->inject(f);
  if (Status s = sim->listen(); !s) return s.error();
  sim->start_ns_ = now_ns();
  sim->thread_ = start_guarded_thread("gauge simulator", [raw = sim.get()] { raw->serve(); }, {});
  return sim;
}

namespace {

// Line time of a request and its reply on a serial bus: 8N1 is 10 bits a character, with
// parity 11, plus 3.5 characters of silence after each frame (Modbus RTU framing).
std::chrono::microseconds rtu_line_time(const SimulatorSettings& s, int request_bytes, int reply_bytes) {
  const double bits_per_char = s.rtu_parity == 'N' ? 10.0 : 11.0;
  const double chars = request_bytes + reply_bytes + 7.0;
  return std::chrono::microseconds(static_cast<std::int64_t>(chars * bits_per_char * 1e6 / s.rtu_baud));
}

}  // namespace

Status GaugeSimulator::listen() {
  if (!settings_.rtu_device.empty()) {
    if (ctx_ != nullptr) return {};
    ctx_ = modbus_new_rtu(settings_.rtu_device.c_str(), settings_.rtu_baud, settings_.rtu_parity, 8, 1);
    if (ctx_ == nullptr) {
      return make_error(ErrorCode::kInvalidInput, "simulator serial line " + settings_.rtu_device + ": " +
                                                      modbus_strerror(errno) + "; check the baud and parity");
    }
    modbus_set_slave(ctx_, settings_.unit_id);
    if (modbus_connect(ctx_) != 0) {
      return make_error(ErrorCode::kIo,
                        "simulator cannot open " + settings_.rtu_device + ": " + modbus_strerror(errno));
    }
    mapping_ = modbus_mapping_new_start_address(0, 0, 0, 0, 0, 0, 0, sim_registers::kCount);
    if (mapping_ == nullptr) return make_error(ErrorCode::kInternal, "cannot allocate the simulator's registers");
    wake_fd_ = ::eventfd(0, EFD_CLOEXEC);
    if (wake_fd_ < 0) return make_error(ErrorCode::kIo, std::string("eventfd: ") + std::strerror(errno));
    return {};
  }
  if (ctx_ == nullptr) {
    // The context only frames requests and replies; the sockets are ours (see serve()). The
    // protocol-independent backend, so the host may be IPv4 or IPv6.
    ctx_ = modbus_new_tcp_pi(settings_.host.c_str(), std::to_string(settings_.port).c_str());
    if (ctx_ == nullptr) {
      return make_error(ErrorCode::kInvalidInput,
                        "simulator address " + settings_.host + " is not usable: " + modbus_strerror(errno));
    }
    mapping_ = modbus_mapping_new_start_address(0, 0, 0, 0, 0, 0, 0, sim_registers::kCount);
    if (mapping_ == nullptr) return make_error(ErrorCode::kInternal, "cannot allocate the simulator's registers");
    wake_fd_ = ::eventfd(0, EFD_CLOEXEC);
    if (wake_fd_ < 0) return make_error(ErrorCode::kIo, std::string("eventfd: ") + std::strerror(errno));
  }
  Result<TcpListener> listener = listen_tcp(settings_.host, port_ != 0 ? port_ : settings_.port, "simulator");
  if (!listener) return listener.error();
  port_ = listener->port;
  listen_fd_ = listener->fd;
  return {};
}

void GaugeSimulator::close_listener() {
  if (listen_fd_ >= 0) {
    ::close(listen_fd_);
    listen_fd_ = -1;
  }
}

void GaugeSimulator::inject(const FaultSpec& fault) {
  std::lock_guard lock(faults_mutex_);
  faults_.push_back(fault);
  delivered_.push_back(false);
}

GaugeSimulator::FaultState GaugeSimulator::fault_state(std::int64_t now_ns, bool deliver) {
  FaultState st;
  if (first_request_ns_ < 0) return st;
  // The schedule runs in revolutions at the nominal speed since the first request.
  const double rev_per_ns = 1e-9 * settings_.time_scale * settings_.speed_rpm / 60.0;
  const double sched_rev = static_cast<double>(now_ns - first_request_ns_) * rev_per_ns;
  std::lock_guard lock(faults_mutex_);
  for (size_t i = 0; i < faults_.size(); ++i) {
    const FaultSpec& f = faults_[i];
    const double end = f.duration_rev < 0.0 ? 1e300 : f.start_rev + f.duration_rev;
    const bool started = sched_rev >= f.start_rev;
    const bool active = started && sched_rev < end;
    switch (f.kind) {
      case FaultKind::kRefuse:
        st.refuse |= active;
        break;
      case FaultKind::kSilent:
        st.silent |= active;
        break;
      case FaultKind::kFrozen:
        st.frozen |= active;
        break;
      case FaultKind::kException:
        if (active) st.exception = f.param > 0 ? static_cast<int>(f.param) : MODBUS_EXCEPTION_SLAVE_OR_SERVER_BUSY;
        break;
      case FaultKind::kOverRange:
        if (active) st.status |= 0x0002;
        break;
      case FaultKind::kUnderRange:
        if (active) st.status |= 0x0004;
        break;
      case FaultKind::kProbeMissing:
        if (active) st.status |= 0x0008;
        break;
      case FaultKind::kSpeedDrift:
        if (started) {
          const double pct = f.param != 0.0 ? f.param : 5.0;
          st.drift_turns += (std::min(sched_rev, end) - f.start_rev) * pct / 100.0;
        }
        break;
      case FaultKind::kAngleJump:
        if (started) st.angle_offset_deg += f.param != 0.0 ? f.param : 30.0;  // for good, once started
        break;
      case FaultKind::kDrop:
      case FaultKind::kLate:
        if (started && !delivered_[i]) {
          if (f.kind == FaultKind::kDrop) st.drop = true;
          if (f.kind == FaultKind::kLate) st.late_ms = f.param > 0 ? static_cast<int>(f.param) : 300;
          if (deliver) delivered_[i] = true;
        }
        break;
    }
  }
  return st;
}

void GaugeSimulator::update_registers(std::int64_t now_ns, const FaultState& faults) {
  if (faults.frozen) {
    was_frozen_ = true;  // the amplifier stands still: same sample, same latch count
    return;
  }
  const std::shared_ptr<const PeriodicSpline> ground = this->ground();  // one part for the whole request
  const double t_s = static_cast<double>(now_ns - start_ns_) * 1e-9 * settings_.time_scale;
  const auto n = static_cast<std::uint64_t>(t_s * settings_.sample_rate_hz);
  const double sample_t_s = static_cast<double>(n) / settings_.sample_rate_hz;  // amplifier holds its last sample
  const double turns = sample_t_s * settings_.speed_rpm / 60.0 + faults.drift_turns;
  const auto whole_turns = static_cast<std::int64_t>(std::floor(turns));
  const double c_deg = (turns - static_cast<double>(whole_turns)) * 360.0;
  const double beta = cam_angle_at_probe_deg(part_, c_deg);
  const double reading_mm = true_lift_mm(ground.get(), beta) + settings_.gauge_offset_mm +
                            settings_.noise_rms_um * 1e-3 * gaussian(settings_.seed, n);
  const std::uint16_t status = static_cast<std::uint16_t>(1u | faults.status);  // ready, plus any fault bits
  // The encoder reports the true angle plus any jump it has suffered.
  double reported_deg = std::fmod(c_deg + faults.angle_offset_deg, 360.0);
  if (reported_deg < 0.0) reported_deg += 360.0;
  const double reported_turns = turns + faults.angle_offset_deg / 360.0;

  std::uint16_t* regs = mapping_->tab_input_registers;
  put_u32(regs, sim_registers::kReading,
          static_cast<std::uint32_t>(static_cast<std::int32_t>(std::lround(reading_mm * 10000.0))));
  regs[sim_registers::kStatus] = status;
  put_u32(regs, sim_registers::kAngle,
          static_cast<std::uint32_t>(std::min(359999.0, std::floor(reported_deg * 1000.0))));
  regs[sim_registers::kRevolution] = static_cast<std::uint16_t>(
      static_cast<std::int64_t>(std::floor(reported_turns - settings_.revolution_lag_deg / 360.0)) & 0xffff);
  regs[sim_registers::kStatusCode] = status_code(status);
  regs[sim_registers::kSequence] = static_cast<std::uint16_t>(n & 0xffff);
  put_u32(regs, sim_registers::kReadingFloat, std::bit_cast<std::uint32_t>(static_cast<float>(reading_mm)));

  // Latch every encoder degree mark passed since the last request (at most a ring's worth:
  // older ones would have been overwritten anyway). Mark i is at C = i mod 360 exactly; the
  // encoder labels it with its own (possibly jumped) degree.
  const auto marks = static_cast<std::int64_t>(std::floor(turns * 360.0)) + 1;
  const auto jump = static_cast<std::int64_t>(std::lround(faults.angle_offset_deg));
  if (was_frozen_) {
    // Back from a freeze: the marks passed meanwhile were never latched. The count jumps
    // ahead over ring entries that still hold old readings; the fault mark counter counts
    // them as lost (status 0: not ready), so a compact reader, which cannot tell an old
    // reading from a new one, knows.
    if (marks - 1 > latched_marks_) {
      fault_marks_ += marks - 1 - latched_marks_;
      fault_mark_status_ = 0;
    }
    latched_marks_ = std::max(latched_marks_, marks - 1);
    was_frozen_ = false;
  }
  if (faults.status != 0 && marks > latched_marks_) {
    fault_marks_ += marks - latched_marks_;  // every mark latched now carries the fault bits
    fault_mark_status_ = status;
  }
  // The latched noise is keyed by the mark counted from the start of the revolution of the
  // first request, not from the spindle's start: a client that measures the revolutions after
  // its first request meets the same noise however long it took to ask (a slower build, a
  // busier machine), so a seeded run repeats.
  if (noise_origin_mark_ < 0) noise_origin_mark_ = (marks - 1) / 360 * 360;
  for (std::int64_t i = std::max(latched_marks_, marks - sim_registers::kCompactRingEntries); i < marks; ++i) {
    const double mark_beta = cam_angle_at_probe_deg(part_, static_cast<double>(i % 360));
    const double mark_mm =
        true_lift_mm(ground.get(), mark_beta) + settings_.gauge_offset_mm +
        settings_.noise_rms_um * 1e-3 *
            gaussian(settings_.seed ^ 0x6c61746368ULL, static_cast<std::uint64_t>(i - noise_origin_mark_));
    const auto counts = static_cast<std::uint32_t>(static_cast<std::int32_t>(std::lround(mark_mm * 10000.0)));
    put_u32(regs, sim_registers::kCompactRing + 2 * static_cast<int>(i % sim_registers::kCompactRingEntries), counts);
    if (i < marks - sim_registers::kLatchRingEntries) continue;  // overwritten in the 4-register ring anyway
    const int at = sim_registers::kLatchRing + 4 * static_cast<int>(i % sim_registers::kLatchRingEntries);
    put_u32(regs, at, counts);
    regs[at + 2] = static_cast<std::uint16_t>(((i + jump) % 360 + 360) % 360);
    regs[at + 3] = status;
  }
  latched_marks_ = std::max(latched_marks_, marks);
  put_u32(regs, sim_registers::kLatchCount, static_cast<std::uint32_t>(latched_marks_ & 0xffffffff));
  regs[sim_registers::kLatchRingSize] = sim_registers::kLatchRingEntries;
  regs[sim_registers::kLatchEntryWords] = 4;
  regs[sim_registers::kCompactRingSize] = sim_registers::kCompactRingEntries;
  put_u32(regs, sim_registers::kFaultMarkCount, static_cast<std::uint32_t>(fault_marks_ & 0xffffffff));
  regs[sim_registers::kFaultMarkStatus] = fault_mark_status_;
}

void GaugeSimulator::serve_rtu() {
  std::vector<std::uint8_t> query(MODBUS_RTU_MAX_ADU_LENGTH);
  const int serial = modbus_get_socket(ctx_);
  while (true) {
    pollfd fds[2] = {{wake_fd_, POLLIN, 0}, {serial, POLLIN, 0}};
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (fds[0].revents != 0) break;  // stop() was called
    const int rc = modbus_receive(ctx_, query.data());
    if (rc <= 0) {
      if (rc < 0) modbus_flush(ctx_);  // a garbled frame: drop it, as a real slave would
      continue;                        // 0: a request for another unit
    }
    const auto received = std::chrono::steady_clock::now();
    ++requests_;
    const std::int64_t t = now_ns();
    if (first_request_ns_ < 0) first_request_ns_ = t;
    const FaultState faults = fault_state(t, /*deliver=*/true);
    update_registers(t, faults);
    if (silent_.load() || faults.silent || faults.drop) continue;
    // Registers requested (functions 03 and 04): the reply carries 2 bytes each.
    const int registers = rc >= 6 ? (query[4] << 8) | query[5] : 0;
    std::this_thread::sleep_until(received + rtu_line_time(settings_, rc, 5 + 2 * registers) +
                                  std::chrono::milliseconds(faults.late_ms));
    if (faults.exception != 0) {
      modbus_reply_exception(ctx_, query.data(), static_cast<unsigned int>(faults.exception));
    } else {
      modbus_reply(ctx_, query.data(), rc, mapping_);
    }
  }
}

void GaugeSimulator::serve() {
  if (!settings_.rtu_device.empty()) {
    serve_rtu();
    return;
  }
  ModbusTcpClients clients;
  while (true) {
    const FaultState now_state = fault_state(now_ns(), /*deliver=*/false);
    if (now_state.refuse && listen_fd_ >= 0) {
      close_listener();  // connection refused from now on
      clients.close_all();
    } else if (!now_state.refuse && listen_fd_ < 0) {
      if (!listen()) break;  // the port was taken meanwhile: nothing sensible left to do
    }
    // While refusing, wake now and then to notice the end of the fault.
    const auto round = clients.serve_round(
        ctx_, wake_fd_, listen_fd_, listen_fd_ < 0 ? 5 : -1, [this](const std::uint8_t* query, int length) {
          ++requests_;
          const std::int64_t t = now_ns();
          if (first_request_ns_ < 0) first_request_ns_ = t;
          const FaultState faults = fault_state(t, /*deliver=*/true);
          update_registers(t, faults);
          if (faults.drop) return false;  // the connection drops mid-run: no reply
          if (silent_.load() || faults.silent) return true;
          if (faults.late_ms > 0) {
            // A late reply: the client has given up by then and must not take it for the next.
            std::this_thread::sleep_for(std::chrono::milliseconds(faults.late_ms));
          }
          if (faults.exception != 0) {
            modbus_reply_exception(ctx_, query, static_cast<unsigned int>(faults.exception));
          } else {
            modbus_reply(ctx_, query, length, mapping_);
          }
          return true;
        });
    if (round != ModbusTcpClients::Round::kServed) break;  // stop() was called, or poll failed
  }
}

void GaugeSimulator::stop() {
  shut_down_modbus_server(thread_, wake_fd_, listen_fd_, ctx_, mapping_, !settings_.rtu_device.empty());
}

GaugeSimulator::~GaugeSimulator() { stop(); }

}  // namespace gaugeloop

// The simulated amplifier: lobe model, clock-driven registers and the libmodbus server loop.
#include "simulator/gauge_simulator.h"

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
#include <vector>

#include "compensation/flat_probe.h"

namespace gaugeloop {
namespace {

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// splitmix64: a well-mixed 64-bit hash, so noise is a pure function of the sample number.
std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

double unit_uniform(std::uint64_t h) { return (static_cast<double>(h >> 11) + 0.5) * (1.0 / 9007199254740992.0); }

// Standard normal deviate for sample n (Box-Muller on two hashed uniforms).
double gaussian(std::uint64_t seed, std::uint64_t n) {
  const double u1 = unit_uniform(mix(seed * 0x100000001b3ULL ^ (2 * n)));
  const double u2 = unit_uniform(mix(seed * 0x100000001b3ULL ^ (2 * n + 1)));
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

void put_u32(std::uint16_t* regs, int at, std::uint32_t v) {
  regs[at] = static_cast<std::uint16_t>(v >> 16);
  regs[at + 1] = static_cast<std::uint16_t>(v & 0xffff);
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
  if (s.port < 0 || s.port > 65535) {
    return make_error(ErrorCode::kInvalidInput, "simulator port must be in [0, 65535]");
  }
  return {};
}

GaugeSimulator::GaugeSimulator(const Part& part, const SimulatorSettings& settings, PeriodicSpline lift)
    : part_(part), settings_(settings), lift_(std::move(lift)) {
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

double GaugeSimulator::lobe_error_um(double cam_angle_deg) const {
  const double b = cam_angle_deg * std::numbers::pi / 180.0;
  const double shape =
      0.7 * lift_.d1(cam_angle_deg) / max_d1_ - 0.5 * lift_.d2(cam_angle_deg) / max_d2_ + 0.2 * std::cos(2.0 * b + 0.4);
  return error_scale_ * shape;
}

double GaugeSimulator::true_lift_mm(double cam_angle_deg) const {
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
  if (Status s = sim->listen(); !s) return s.error();
  sim->start_ns_ = now_ns();
  sim->thread_ = std::thread([raw = sim.get()] { raw->serve(); });
  return sim;
}

Status GaugeSimulator::listen() {
  ctx_ = modbus_new_tcp(settings_.host.c_str(), settings_.port);
  if (ctx_ == nullptr) {
    return make_error(ErrorCode::kInvalidInput,
                      "simulator address " + settings_.host + " is not usable: " + modbus_strerror(errno));
  }
  mapping_ = modbus_mapping_new_start_address(0, 0, 0, 0, 0, 0, 0, sim_registers::kCount);
  if (mapping_ == nullptr) return make_error(ErrorCode::kInternal, "cannot allocate the simulator's registers");
  listen_fd_ = modbus_tcp_listen(ctx_, 16);
  if (listen_fd_ < 0) {
    return make_error(ErrorCode::kIo, "simulator cannot listen on " + settings_.host + ":" +
                                          std::to_string(settings_.port) + ": " + modbus_strerror(errno) +
                                          "; choose another port or 0 for any free one");
  }
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  if (::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    return make_error(ErrorCode::kIo, std::string("simulator cannot read its port back: ") + std::strerror(errno));
  }
  port_ = ntohs(addr.sin_port);
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC);
  if (wake_fd_ < 0) return make_error(ErrorCode::kIo, std::string("eventfd: ") + std::strerror(errno));
  return {};
}

void GaugeSimulator::update_registers() {
  const double t_s = static_cast<double>(now_ns() - start_ns_) * 1e-9 * settings_.time_scale;
  const auto n = static_cast<std::uint64_t>(t_s * settings_.sample_rate_hz);
  const double sample_t_s = static_cast<double>(n) / settings_.sample_rate_hz;  // amplifier holds its last sample
  const double turns = sample_t_s * settings_.speed_rpm / 60.0;
  const auto whole_turns = static_cast<std::int64_t>(std::floor(turns));
  const double c_deg = (turns - static_cast<double>(whole_turns)) * 360.0;
  const double beta = cam_angle_at_probe_deg(part_, c_deg);
  const double reading_mm =
      true_lift_mm(beta) + settings_.gauge_offset_mm + settings_.noise_rms_um * 1e-3 * gaussian(settings_.seed, n);

  std::uint16_t* regs = mapping_->tab_input_registers;
  put_u32(regs, sim_registers::kReading,
          static_cast<std::uint32_t>(static_cast<std::int32_t>(std::lround(reading_mm * 10000.0))));
  regs[sim_registers::kStatus] = 1;  // ready
  put_u32(regs, sim_registers::kAngle, static_cast<std::uint32_t>(std::min(359999.0, std::floor(c_deg * 1000.0))));
  regs[sim_registers::kRevolution] = static_cast<std::uint16_t>(whole_turns & 0xffff);
  regs[sim_registers::kSequence] = static_cast<std::uint16_t>(n & 0xffff);
  put_u32(regs, sim_registers::kReadingFloat, std::bit_cast<std::uint32_t>(static_cast<float>(reading_mm)));

  // Latch every encoder degree mark passed since the last request (at most a ring's worth:
  // older ones would have been overwritten anyway). Mark i is C = i mod 360, exactly.
  const auto marks = static_cast<std::int64_t>(std::floor(turns * 360.0)) + 1;
  for (std::int64_t i = std::max(latched_marks_, marks - sim_registers::kLatchRingEntries); i < marks; ++i) {
    const double mark_beta = cam_angle_at_probe_deg(part_, static_cast<double>(i % 360));
    const double mark_mm =
        true_lift_mm(mark_beta) + settings_.gauge_offset_mm +
        settings_.noise_rms_um * 1e-3 * gaussian(settings_.seed ^ 0x6c61746368ULL, static_cast<std::uint64_t>(i));
    const int at = sim_registers::kLatchRing + 4 * static_cast<int>(i % sim_registers::kLatchRingEntries);
    put_u32(regs, at, static_cast<std::uint32_t>(static_cast<std::int32_t>(std::lround(mark_mm * 10000.0))));
    regs[at + 2] = static_cast<std::uint16_t>(i % 360);
    regs[at + 3] = 1;  // ready
  }
  latched_marks_ = std::max(latched_marks_, marks);
  put_u32(regs, sim_registers::kLatchCount, static_cast<std::uint32_t>(latched_marks_ & 0xffffffff));
  regs[sim_registers::kLatchRingSize] = sim_registers::kLatchRingEntries;
  regs[sim_registers::kLatchEntryWords] = 4;

  if (first_request_revolution_ < 0) first_request_revolution_ = whole_turns;
  if (settings_.silent_after_revolutions >= 0 &&
      whole_turns - first_request_revolution_ >= settings_.silent_after_revolutions) {
    silent_.store(true);
  }
}

void GaugeSimulator::serve() {
  std::vector<int> clients;
  std::vector<std::uint8_t> query(MODBUS_TCP_MAX_ADU_LENGTH);
  while (true) {
    std::vector<pollfd> fds;
    fds.push_back({wake_fd_, POLLIN, 0});
    fds.push_back({listen_fd_, POLLIN, 0});
    for (int c : clients) fds.push_back({c, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (fds[0].revents != 0) break;  // stop() was called
    if (fds[1].revents & POLLIN) {
      const int c = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (c >= 0) clients.push_back(c);
    }
    std::vector<int> closed;
    for (size_t i = 2; i < fds.size(); ++i) {
      if (fds[i].revents == 0) continue;
      const int fd = fds[i].fd;
      modbus_set_socket(ctx_, fd);
      const int rc = modbus_receive(ctx_, query.data());
      if (rc > 0) {
        ++requests_;
        update_registers();
        if (!silent_.load()) modbus_reply(ctx_, query.data(), rc, mapping_);
      } else if (rc < 0) {
        closed.push_back(fd);  // client went away or sent garbage
      }
    }
    for (int fd : closed) {
      ::close(fd);
      clients.erase(std::remove(clients.begin(), clients.end(), fd), clients.end());
    }
  }
  for (int c : clients) ::close(c);
}

void GaugeSimulator::stop() {
  if (thread_.joinable()) {
    const std::uint64_t one = 1;
    [[maybe_unused]] auto w = ::write(wake_fd_, &one, sizeof one);
    thread_.join();
  }
  if (listen_fd_ >= 0) {
    ::close(listen_fd_);
    listen_fd_ = -1;
  }
  if (wake_fd_ >= 0) {
    ::close(wake_fd_);
    wake_fd_ = -1;
  }
  if (ctx_ != nullptr) {
    modbus_set_socket(ctx_, -1);  // sockets were closed above; keep modbus_free from closing again
    modbus_free(ctx_);
    ctx_ = nullptr;
  }
  if (mapping_ != nullptr) {
    modbus_mapping_free(mapping_);
    mapping_ = nullptr;
  }
}

GaugeSimulator::~GaugeSimulator() { stop(); }

}  // namespace gaugeloop

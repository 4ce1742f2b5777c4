// The virtual gear grinder's flank probe: its libmodbus server loop.
#include "simulator/gear_probe_simulator.h"

#include <modbus/modbus.h>
#include <unistd.h>

#include <cmath>

#include "core/gear_probe_registers.h"
#include "core/guarded_thread.h"
#include "simulator/tcp_listener.h"

namespace gaugeloop {

namespace gp = gear_probe_registers;

GearProbeSimulator::GearProbeSimulator(GearProbeSimulatorSettings settings) : settings_(std::move(settings)) {}

Result<std::unique_ptr<GearProbeSimulator>> GearProbeSimulator::start(const GearProbeSimulatorSettings& settings) {
  std::unique_ptr<GearProbeSimulator> sim(new GearProbeSimulator(settings));
  if (Status s = open_holding_register_server(settings.host, settings.port, settings.base_address, gp::kBlockWords,
                                              "gear probe simulator", sim->ctx_, sim->mapping_, sim->wake_fd_);
      !s) {
    return s.error();
  }
  Result<TcpListener> listener = listen_tcp(settings.host, settings.port, "gear probe simulator");
  if (!listener) return listener.error();
  sim->port_ = listener->port;
  sim->listen_fd_ = listener->fd;
  sim->thread_ = start_guarded_thread("gear probe simulator", [raw = sim.get()] { raw->serve(); }, {});
  return sim;
}

void GearProbeSimulator::answer_request() {
  std::uint16_t* w = mapping_->tab_registers;
  const std::uint16_t sequence = w[gp::kRequestSequence];
  if (sequence == 0 || sequence == w[gp::kAnswerSequence] || stalled_) return;
  const int gap = w[gp::kGap];
  const Flank flank = w[gp::kFlank] == 0 ? Flank::kLeft : Flank::kRight;
  const auto z_units = static_cast<std::int32_t>((static_cast<std::uint32_t>(w[gp::kZ]) << 16) | w[gp::kZ + 1]);
  const double z_mm = z_units * gp::kZUnitMm;
  std::uint16_t status = status_;
  double deviation_um = 0.0;
  if (!gear_) {
    status |= gp::kProbeFault;  // no gear on the machine
  } else if (gap < 1 || gap > gear_->part().gear.teeth || w[gp::kFlank] > 1 ||
             std::abs(z_mm) > gear_->part().gear.face_width_mm / 2.0 + 1e-9) {
    status |= gp::kOutOfReach;
  } else {
    deviation_um = probed_deviation_um(*gear_, measurement_, gap, flank, z_mm);
  }
  const auto nm = static_cast<std::int32_t>(std::lround(deviation_um / gp::kDeviationUnitUm));
  w[gp::kStatus] = status;
  w[gp::kDeviation] = static_cast<std::uint16_t>(static_cast<std::uint32_t>(nm) >> 16);
  w[gp::kDeviation + 1] = static_cast<std::uint16_t>(static_cast<std::uint32_t>(nm) & 0xFFFFu);
  w[gp::kZMeasured] = w[gp::kZ];
  w[gp::kZMeasured + 1] = w[gp::kZ + 1];
  w[gp::kAnswerSequence] = sequence;  // last: the answer is whole when its sequence shows
  ++answered_;
}

void GearProbeSimulator::serve() {
  ModbusTcpClients clients;
  while (!stopping_.load()) {
    {
      std::lock_guard lock(mutex_);
      if (drops_done_ < drops_asked_) {
        clients.close_all();
        drops_done_ = drops_asked_;
        dropped_.notify_all();
      }
    }
    const auto round =
        clients.serve_round(ctx_, wake_fd_, listen_fd_, -1, [this](const std::uint8_t* query, int length) {
          std::lock_guard lock(mutex_);
          // The mapping's addresses start at the base: the block's words are tab_registers[0..10].
          modbus_reply(ctx_, query, length, mapping_);
          answer_request();
          return true;
        });
    if (round == ModbusTcpClients::Round::kFailed) break;
    if (round == ModbusTcpClients::Round::kWoken) {
      std::uint64_t n = 0;
      [[maybe_unused]] auto rd = ::read(wake_fd_, &n, sizeof n);
    }
  }
}

void GearProbeSimulator::load_gear(GroundGear gear, std::uint64_t measurement) {
  std::lock_guard lock(mutex_);
  gear_.emplace(std::move(gear));
  measurement_ = measurement;
}

void GearProbeSimulator::set_stalled(bool stalled) {
  std::lock_guard lock(mutex_);
  stalled_ = stalled;
}

void GearProbeSimulator::set_status(std::uint16_t status) {
  std::lock_guard lock(mutex_);
  status_ = status;
}

void GearProbeSimulator::drop_connections() {
  std::unique_lock lock(mutex_);
  const std::int64_t mine = ++drops_asked_;
  const std::uint64_t one = 1;
  [[maybe_unused]] auto w = ::write(wake_fd_, &one, sizeof one);
  dropped_.wait(lock, [&] { return drops_done_ >= mine || stopping_.load(); });
}

void GearProbeSimulator::stop() {
  shut_down_modbus_server(thread_, wake_fd_, listen_fd_, ctx_, mapping_, /*serial=*/false, [this] {
    stopping_.store(true);
    std::lock_guard lock(mutex_);
    dropped_.notify_all();
  });
}

GearProbeSimulator::~GearProbeSimulator() { stop(); }

}  // namespace gaugeloop

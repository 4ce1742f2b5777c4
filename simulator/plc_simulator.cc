// The virtual PLC's libmodbus server loop and its handshake API.
#include "simulator/plc_simulator.h"
#include "core/guarded_thread.h"
#include "simulator/tcp_listener.h"

#include <arpa/inet.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <vector>

namespace gaugeloop {

namespace r = plc_registers;

PlcSimulator::PlcSimulator(PlcSimulatorSettings settings) : settings_(std::move(settings)) {}

Result<std::unique_ptr<PlcSimulator>> PlcSimulator::start(const PlcSimulatorSettings& settings) {
  std::unique_ptr<PlcSimulator> sim(new PlcSimulator(settings));
  const int words = settings.part_temperature ? r::kBlockWordsWithTemperature : r::kBlockWords;
  if (Status s = open_holding_register_server(settings.host, settings.port, settings.base_address, words,
                                              "PLC simulator", sim->ctx_, sim->mapping_, sim->wake_fd_);
      !s) {
    return s.error();
  }
  // A PLC that gives no part temperature: word 37 holds "not given", not 0.0 deg C.
  if (settings.part_temperature) sim->mapping_->tab_registers[r::kPartTemperature] = r::kPartTemperatureNotGiven;
  if (Status s = sim->listen(); !s) return s.error();
  sim->thread_ = start_guarded_thread("PLC simulator", [raw = sim.get()] { raw->serve(); }, {});
  return sim;
}

Status PlcSimulator::listen() {
  Result<TcpListener> listener = listen_tcp(settings_.host, port_ != 0 ? port_ : settings_.port, "PLC simulator");
  if (!listener) return listener.error();
  port_ = listener->port;
  listen_fd_ = listener->fd;
  return {};
}

void PlcSimulator::wake() const {
  const std::uint64_t one = 1;
  [[maybe_unused]] auto w = ::write(wake_fd_, &one, sizeof one);
}

void PlcSimulator::serve() {
  ModbusTcpClients clients;
  while (!stopping_.load()) {
    // Read before carrying out: a change asked for after this is seen by the next round.
    const std::int64_t asked = link_requests_.load();
    if (drop_.exchange(false)) clients.close_all();
    if (refusing_.load() && listen_fd_ >= 0) {
      ::close(listen_fd_);  // connection refused from now on
      listen_fd_ = -1;
      clients.close_all();
    } else if (!refusing_.load() && listen_fd_ < 0) {
      if (!listen()) break;  // the port was taken meanwhile: nothing sensible left to do
    }
    {
      std::lock_guard lock(mutex_);
      link_changes_ = asked;
    }
    written_.notify_all();
    const auto round =
        clients.serve_round(ctx_, wake_fd_, listen_fd_, -1, [this](const std::uint8_t* query, int length) {
          const int function = query[static_cast<size_t>(modbus_get_header_length(ctx_))];
          {
            std::lock_guard lock(mutex_);
            modbus_reply(ctx_, query, length, mapping_);
            if (function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS || function == MODBUS_FC_WRITE_SINGLE_REGISTER)
              ++writes_;
          }
          written_.notify_all();
          return true;
        });
    if (round == ModbusTcpClients::Round::kFailed) break;
    if (round == ModbusTcpClients::Round::kWoken) {
      std::uint64_t n = 0;
      [[maybe_unused]] auto rd = ::read(wake_fd_, &n, sizeof n);  // stop, drop or refuse: seen at the top
    }
  }
}

void PlcSimulator::request(std::uint16_t part_number, std::uint16_t lobe, std::uint16_t ground_with) {
  std::lock_guard lock(mutex_);
  mapping_->tab_registers[r::kPartNumber] = part_number;
  mapping_->tab_registers[r::kLobe] = lobe;
  mapping_->tab_registers[r::kGroundWith] = ground_with;
  mapping_->tab_registers[r::kRequest] |= r::kMeasureBit;
}

Status PlcSimulator::set_identity(std::string_view serial, std::string_view operator_name) {
  std::array<std::uint16_t, r::kSerialWords> serial_words{};
  std::array<std::uint16_t, r::kOperatorWords> operator_words{};
  if (Status s = encode_plc_text(serial, serial_words); !s) return s;
  if (Status s = encode_plc_text(operator_name, operator_words); !s) return s;
  std::lock_guard lock(mutex_);
  std::copy(serial_words.begin(), serial_words.end(), mapping_->tab_registers + r::kSerialFirst);
  std::copy(operator_words.begin(), operator_words.end(), mapping_->tab_registers + r::kOperatorFirst);
  return {};
}

Status PlcSimulator::set_part_temperature_c(std::optional<double> temperature_c) {
  if (!settings_.part_temperature) {
    return make_error(ErrorCode::kInvalidInput, "PLC simulator: started without the part temperature word");
  }
  Result<std::uint16_t> word = encode_plc_part_temperature(temperature_c);
  if (!word) return word.error();
  std::lock_guard lock(mutex_);
  mapping_->tab_registers[r::kPartTemperature] = *word;
  return {};
}

void PlcSimulator::clear_request() {
  std::lock_guard lock(mutex_);
  mapping_->tab_registers[r::kRequest] &= static_cast<std::uint16_t>(~r::kMeasureBit);
}

PlcRequestWords PlcSimulator::plc_words() const {
  std::lock_guard lock(mutex_);
  PlcRequestWords w;
  w.request = mapping_->tab_registers[r::kRequest];
  w.part_number = mapping_->tab_registers[r::kPartNumber];
  w.lobe = mapping_->tab_registers[r::kLobe];
  w.ground_with = mapping_->tab_registers[r::kGroundWith];
  std::copy_n(mapping_->tab_registers + r::kSerialFirst, r::kSerialWords, w.serial.begin());
  std::copy_n(mapping_->tab_registers + r::kOperatorFirst, r::kOperatorWords, w.operator_name.begin());
  w.part_temperature =
      settings_.part_temperature ? mapping_->tab_registers[r::kPartTemperature] : r::kPartTemperatureNotGiven;
  return w;
}

namespace {

PlcServiceWords read_service(const modbus_mapping_t* m) {
  std::array<std::uint16_t, r::kServiceWords> regs{};
  std::copy_n(m->tab_registers + r::kServiceFirst, r::kServiceWords, regs.begin());
  return decode_service_words(regs);
}

}  // namespace

PlcServiceWords PlcSimulator::service_words() const {
  std::lock_guard lock(mutex_);
  return read_service(mapping_);
}

std::int64_t PlcSimulator::service_writes() const {
  std::lock_guard lock(mutex_);
  return writes_;
}

std::optional<PlcServiceWords> PlcSimulator::wait_until(const std::function<bool(const PlcServiceWords&)>& done,
                                                        std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  std::optional<PlcServiceWords> seen;
  const bool ok = written_.wait_for(lock, timeout, [&] {
    seen = read_service(mapping_);
    return done(*seen);
  });
  if (!ok) return std::nullopt;
  return seen;
}

std::optional<PlcServiceWords> PlcSimulator::wait_for_outcome(std::chrono::milliseconds timeout) const {
  return wait_until([](const PlcServiceWords& w) { return w.done || w.fault; }, timeout);
}

void PlcSimulator::change_link(const std::function<void()>& apply) {
  std::unique_lock lock(mutex_);
  apply();
  const std::int64_t mine = ++link_requests_;
  wake();
  written_.wait(lock, [&] { return link_changes_ >= mine || stopping_.load(); });
}

void PlcSimulator::drop_connections() {
  change_link([this] { drop_.store(true); });
}

void PlcSimulator::set_refusing(bool refusing) {
  change_link([this, refusing] { refusing_.store(refusing); });
}

void PlcSimulator::stop() {
  shut_down_modbus_server(thread_, wake_fd_, listen_fd_, ctx_, mapping_, /*serial=*/false,
                          [this] { stopping_.store(true); });
}

PlcSimulator::~PlcSimulator() { stop(); }

}  // namespace gaugeloop

// ModbusContext: a libmodbus context opened from ModbusSettings, and each failure turned into
// the peer's error code and a message naming the registers, the device and what to check.
// Against the PLC simulator over a real loopback socket (port 0, read back).
#include "acquisition/modbus_context.h"

#include <gtest/gtest.h>

#include <array>
#include <string>

#include "simulator/plc_simulator.h"

namespace gaugeloop {
namespace {

bool starts_with(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }
bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

ModbusPeer widget() {
  return ModbusPeer{"widget",
                    ErrorCode::kGaugeUnreachable,
                    ErrorCode::kGaugeTimeout,
                    ErrorCode::kGaugeProtocol,
                    "; check A",
                    "; check B",
                    "; check C"};
}

class ModbusContextTest : public ::testing::Test {
 protected:
  void SetUp() override {
    PlcSimulatorSettings s;
    s.base_address = 400;
    auto sim = PlcSimulator::start(s);
    ASSERT_TRUE(sim.ok()) << sim.error().message;
    sim_ = std::move(*sim);
    settings_.host = "127.0.0.1";
    settings_.port = sim_->port();
    settings_.response_timeout = std::chrono::milliseconds(2000);  // generous: loopback under sanitizers
    where_ = "of the widget at tcp:127.0.0.1:" + std::to_string(sim_->port());
  }

  std::unique_ptr<PlcSimulator> sim_;
  ModbusSettings settings_;
  std::string where_;
  std::array<std::uint16_t, 13> regs_{};
};

TEST_F(ModbusContextTest, ReadsAndWritesOnceOpen) {
  ModbusContext ctx(settings_, widget());
  EXPECT_FALSE(ctx.is_open());
  ASSERT_TRUE(ctx.open().ok());
  EXPECT_TRUE(ctx.is_open());
  EXPECT_TRUE(ctx.read_registers(RegisterTable::kHolding, 400, 13, regs_.data()).ok());
  EXPECT_TRUE(ctx.write_registers(403, 9, regs_.data() + 3).ok());
  ctx.close();
  EXPECT_FALSE(ctx.is_open());
}

TEST_F(ModbusContextTest, AnExceptionReplyIsThePeersProtocolErrorAndTheLinkStays) {
  ModbusContext ctx(settings_, widget());
  ASSERT_TRUE(ctx.open().ok());
  Status s = ctx.read_registers(RegisterTable::kHolding, 0, 13, regs_.data());
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kGaugeProtocol);
  EXPECT_TRUE(starts_with(s.error().message, "reading holding registers 0..12 " + where_ + ": ")) << s.error().message;
  EXPECT_TRUE(ends_with(s.error().message, "; check C")) << s.error().message;
  EXPECT_TRUE(ctx.is_open());
}

TEST_F(ModbusContextTest, ALostLinkIsThePeersUnreachableErrorAndClosesIt) {
  ModbusContext ctx(settings_, widget());
  ASSERT_TRUE(ctx.open().ok());
  ASSERT_TRUE(ctx.read_registers(RegisterTable::kHolding, 400, 13, regs_.data()).ok());  // accepted: then dropped
  sim_->drop_connections();
  Status s = ctx.write_registers(403, 9, regs_.data());
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kGaugeUnreachable);
  EXPECT_TRUE(starts_with(s.error().message, "writing holding registers 403..411 " + where_ + ": "))
      << s.error().message;
  EXPECT_TRUE(ends_with(s.error().message, " (link lost)")) << s.error().message;
  EXPECT_FALSE(ctx.is_open());

  Status closed = ctx.read_registers(RegisterTable::kInput, 400, 13, regs_.data());
  ASSERT_FALSE(closed.ok());
  EXPECT_EQ(closed.error().code, ErrorCode::kGaugeUnreachable);
  EXPECT_EQ(closed.error().message, "widget at tcp:127.0.0.1:" + std::to_string(sim_->port()) + " is not connected");
}

TEST_F(ModbusContextTest, ARefusedConnectionNamesThePeerAndWhatToCheck) {
  sim_->set_refusing(true);
  ModbusContext ctx(settings_, widget());
  Status s = ctx.open();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kGaugeUnreachable);
  EXPECT_TRUE(starts_with(s.error().message, "cannot connect to the widget at tcp:127.0.0.1:")) << s.error().message;
  EXPECT_TRUE(ends_with(s.error().message, "; check B")) << s.error().message;
  EXPECT_FALSE(ctx.is_open());
}

TEST(ModbusContext, SettingsLibmodbusRefusesAreInvalidInput) {
  ModbusSettings s;
  s.transport = ModbusTransport::kRtu;
  s.device = "/dev/ttyUSB9";
  s.parity = 'X';
  ModbusContext ctx(s, widget());
  Status opened = ctx.open();
  ASSERT_FALSE(opened.ok());
  EXPECT_EQ(opened.error().code, ErrorCode::kInvalidInput);
  EXPECT_TRUE(starts_with(opened.error().message, "widget address rtu:/dev/ttyUSB9@115200/X/unit 1 is not usable: "))
      << opened.error().message;
  EXPECT_TRUE(ends_with(opened.error().message, "; check A")) << opened.error().message;
}

TEST(ModbusContext, AHostThatDoesNotResolveIsInvalidInput) {
  ModbusSettings s;
  s.host = "widget.invalid";
  ModbusContext ctx(s, widget());
  Status opened = ctx.open();
  ASSERT_FALSE(opened.ok());
  EXPECT_EQ(opened.error().code, ErrorCode::kInvalidInput);
  EXPECT_TRUE(starts_with(opened.error().message, "cannot resolve host 'widget.invalid': ")) << opened.error().message;
}

TEST(ModbusAddress, NamesTheTransport) {
  ModbusSettings s;
  s.host = "::1";
  s.port = 1502;
  EXPECT_EQ(modbus_address(s), "tcp:[::1]:1502");
  s.transport = ModbusTransport::kRtu;
  s.device = "/dev/ttyS0";
  s.baud = 19200;
  s.parity = 'E';
  s.unit_id = 7;
  EXPECT_EQ(modbus_address(s), "rtu:/dev/ttyS0@19200/E/unit 7");
}

}  // namespace
}  // namespace gaugeloop

// The PLC link against the PLC simulator over a real loopback socket: the handshake block
// read and written where the config puts it, a wrong base address, a dropped and a refused link.
#include "acquisition/plc_link.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <optional>
#include <string>

#include "simulator/plc_simulator.h"

namespace gaugeloop {
namespace {

using std::chrono::milliseconds;

class PlcLinkTest : public ::testing::Test {
 protected:
  void SetUp() override {
    PlcSimulatorSettings s;
    s.base_address = 400;
    auto sim = PlcSimulator::start(s);
    ASSERT_TRUE(sim.ok()) << sim.error().message;
    sim_ = std::move(*sim);
    ASSERT_GT(sim_->port(), 0);
  }

  PlcLinkSettings settings(int base_address = 400) const {
    PlcLinkSettings s;
    s.link.host = "127.0.0.1";
    s.link.port = sim_->port();
    s.link.response_timeout = milliseconds(2000);  // generous: loopback under sanitizers
    s.base_address = base_address;
    return s;
  }

  std::unique_ptr<PlcSimulator> sim_;
};

TEST_F(PlcLinkTest, ReadsThePlcsWordsAndWritesTheServicesAtTheBaseAddress) {
  ModbusPlcLink link(settings());
  ASSERT_TRUE(link.connect().ok());
  Result<PlcRequestWords> idle = link.read_request();
  ASSERT_TRUE(idle.ok()) << idle.error().message;
  EXPECT_FALSE(idle->measure());

  sim_->request(7, 2);
  Result<PlcRequestWords> req = link.read_request();
  ASSERT_TRUE(req.ok()) << req.error().message;
  EXPECT_TRUE(req->measure());
  EXPECT_EQ(req->part_number, 7);
  EXPECT_EQ(req->lobe, 2);

  PlcServiceWords w;
  w.heartbeat = 65535;
  w.ack = true;
  w.done = true;
  w.result_code = PlcResultCode::kTableHeld;
  w.run_id = 0x00010002;
  w.table_version = 9;
  ASSERT_TRUE(link.write_service_words(w).ok());
  EXPECT_EQ(sim_->service_words(), w);
  EXPECT_EQ(sim_->service_writes(), 1) << "one request for the whole block";
  EXPECT_EQ(sim_->plc_words().part_number, 7) << "the PLC's words are not written by the service";

  sim_->clear_request();
  req = link.read_request();
  ASSERT_TRUE(req.ok());
  EXPECT_FALSE(req->measure());
}

TEST_F(PlcLinkTest, CarriesTheSerialNumberAndOperatorInTheSameRead) {
  ModbusPlcLink link(settings());
  ASSERT_TRUE(link.connect().ok());
  ASSERT_TRUE(sim_->set_identity("CAM-2026-000417", "anna").ok());
  sim_->request(7, 2);
  Result<PlcRequestWords> req = link.read_request();
  ASSERT_TRUE(req.ok()) << req.error().message;
  EXPECT_EQ(req->part_number, 7);
  // High byte first: 'C' (0x43) then 'A' (0x41), as an S7 Char array lies in the registers.
  EXPECT_EQ(req->serial[0], 0x4341);
  EXPECT_EQ(req->serial[7], 0x3700) << "15 characters: the last word ends with the NUL";
  EXPECT_EQ(req->serial[8], 0);
  EXPECT_EQ(req->operator_name[0], 0x616e);  // "an"
  Result<std::string> serial = decode_plc_text(req->serial, plc_registers::kSerialFirst, 400, "serial number");
  ASSERT_TRUE(serial.ok()) << serial.error().message;
  EXPECT_EQ(*serial, "CAM-2026-000417");
  Result<std::string> who = decode_plc_text(req->operator_name, plc_registers::kOperatorFirst, 400, "operator");
  ASSERT_TRUE(who.ok()) << who.error().message;
  EXPECT_EQ(*who, "anna");
  EXPECT_EQ(sim_->service_writes(), 0) << "the PLC's words are only read";
}

TEST_F(PlcLinkTest, AThirtyTwoCharacterSerialFillsEveryWordAndComesBackWhole) {
  const std::string serial = "0123456789ABCDEFGHIJKLMNOPQRSTUV";
  ASSERT_EQ(serial.size(), 32u);
  const std::string operator_name = "badge-1234567890";
  ASSERT_EQ(operator_name.size(), 16u);
  ASSERT_TRUE(sim_->set_identity(serial, operator_name).ok());
  ModbusPlcLink link(settings());
  ASSERT_TRUE(link.connect().ok());
  Result<PlcRequestWords> req = link.read_request();
  ASSERT_TRUE(req.ok()) << req.error().message;
  for (std::uint16_t w : req->serial) {
    EXPECT_NE(w >> 8, 0) << "no NUL anywhere";
    EXPECT_NE(w & 0xff, 0) << "no NUL anywhere";
  }
  EXPECT_EQ(req->serial.back(), ('U' << 8) | 'V') << "no terminator: the last word holds text";
  EXPECT_EQ(req->operator_name.back(), ('9' << 8) | '0');
  Result<std::string> back = decode_plc_text(req->serial, plc_registers::kSerialFirst, 400, "serial number");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(*back, serial);
  Result<std::string> who = decode_plc_text(req->operator_name, plc_registers::kOperatorFirst, 400, "operator");
  ASSERT_TRUE(who.ok()) << who.error().message;
  EXPECT_EQ(*who, operator_name);

  Status longer = sim_->set_identity(serial + "W", "");
  ASSERT_FALSE(longer.ok());
  EXPECT_NE(longer.error().message.find("33 characters"), std::string::npos) << longer.error().message;
  EXPECT_EQ(sim_->plc_words().serial.back(), ('U' << 8) | 'V') << "nothing written";
}

// Word 37 comes in the same read as the rest of the block: a simulated PLC that gives no
// temperature holds 0x8000, "not given"; 21.4 deg C is 214, -1.5 is -15 as an int16.
TEST_F(PlcLinkTest, CarriesThePartTemperatureWordInTheSameRead) {
  PlcLinkSettings with = settings();
  with.part_temperature = true;
  ModbusPlcLink link(with);
  ASSERT_TRUE(link.connect().ok());
  auto read_word = [&link]() -> std::uint16_t {
    Result<PlcRequestWords> req = link.read_request();
    EXPECT_TRUE(req.ok()) << req.error().message;
    return req ? req->part_temperature : 0;
  };
  EXPECT_EQ(read_word(), plc_registers::kPartTemperatureNotGiven) << "a fresh PLC gives none";
  Result<std::optional<double>> none = decode_plc_part_temperature(read_word(), 400);
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_FALSE(none->has_value());

  ASSERT_TRUE(sim_->set_part_temperature_c(21.4).ok());
  EXPECT_EQ(read_word(), 214);
  Result<std::optional<double>> warm = decode_plc_part_temperature(read_word(), 400);
  ASSERT_TRUE(warm.ok()) << warm.error().message;
  ASSERT_TRUE(warm->has_value());
  EXPECT_DOUBLE_EQ(**warm, 21.4);

  ASSERT_TRUE(sim_->set_part_temperature_c(-1.5).ok());
  EXPECT_EQ(read_word(), 0xFFF1);
  Result<std::optional<double>> cold = decode_plc_part_temperature(read_word(), 400);
  ASSERT_TRUE(cold.ok() && cold->has_value());
  EXPECT_DOUBLE_EQ(**cold, -1.5);

  // A value the service refuses still goes into the word; one the word cannot hold does not.
  ASSERT_TRUE(sim_->set_part_temperature_c(200.0).ok());
  EXPECT_EQ(read_word(), 2000);
  Result<std::optional<double>> hot = decode_plc_part_temperature(read_word(), 400);
  ASSERT_FALSE(hot.ok());
  EXPECT_NE(hot.error().message.find("word 37 (holding register 437) is 2000, 200.0 deg C"), std::string::npos)
      << hot.error().message;
  EXPECT_FALSE(sim_->set_part_temperature_c(4000.0).ok());
  EXPECT_FALSE(sim_->set_part_temperature_c(std::nan("")).ok());
  EXPECT_EQ(read_word(), 2000) << "nothing written";

  ASSERT_TRUE(sim_->set_part_temperature_c(std::nullopt).ok());
  EXPECT_EQ(read_word(), plc_registers::kPartTemperatureNotGiven);
  EXPECT_EQ(sim_->plc_words().part_temperature, plc_registers::kPartTemperatureNotGiven);
  EXPECT_EQ(sim_->service_writes(), 0) << "the PLC's words are only read";
}

// A PLC program written for the 37-word block (no part temperature) keeps working with the
// default settings; told to read the temperature word, the link gets the PLC's exception,
// naming the setting.
TEST(PlcLinkBlock, AProgramWithoutTheTemperatureWordAnswersTheDefaultBlock) {
  PlcSimulatorSettings old;
  old.part_temperature = false;
  Result<std::unique_ptr<PlcSimulator>> sim = PlcSimulator::start(old);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  PlcLinkSettings s;
  s.link.host = "127.0.0.1";
  s.link.port = (*sim)->port();
  s.link.response_timeout = milliseconds(2000);
  ModbusPlcLink link(s);
  ASSERT_TRUE(link.connect().ok());
  Result<PlcRequestWords> req = link.read_request();
  ASSERT_TRUE(req.ok()) << req.error().message;
  EXPECT_EQ(req->part_temperature, plc_registers::kPartTemperatureNotGiven);
  EXPECT_FALSE((*sim)->set_part_temperature_c(21.0).ok()) << "no such word on this PLC";

  s.part_temperature = true;
  ModbusPlcLink asks_for_it(s);
  ASSERT_TRUE(asks_for_it.connect().ok());
  req = asks_for_it.read_request();
  ASSERT_FALSE(req.ok());
  EXPECT_NE(req.error().message.find("part_temperature"), std::string::npos) << req.error().message;
  EXPECT_NE(req.error().message.find("0..37"), std::string::npos) << req.error().message;
}

TEST_F(PlcLinkTest, AllZeroIdentityWordsAreNoSerialAndNoOperator) {
  ModbusPlcLink link(settings());
  ASSERT_TRUE(link.connect().ok());
  ASSERT_TRUE(sim_->set_identity("A123", "anna").ok());
  ASSERT_TRUE(sim_->set_identity("", "").ok());
  Result<PlcRequestWords> req = link.read_request();
  ASSERT_TRUE(req.ok()) << req.error().message;
  for (std::uint16_t w : req->serial) EXPECT_EQ(w, 0);
  for (std::uint16_t w : req->operator_name) EXPECT_EQ(w, 0);
  Result<std::string> serial = decode_plc_text(req->serial, plc_registers::kSerialFirst, 400, "serial number");
  ASSERT_TRUE(serial.ok()) << serial.error().message;
  EXPECT_EQ(*serial, "");
}

// The text rules, without a link.
TEST(PlcText, EndsAtTheFirstNulAndTrimsSpacePadding) {
  std::array<std::uint16_t, 4> words{};
  ASSERT_TRUE(encode_plc_text("  A1 2  ", words).ok());
  EXPECT_EQ(*decode_plc_text(words, 13, 0, "serial number"), "A1 2") << "inner spaces stay";
  words = {('A' << 8) | 'B', 'C' << 8, ('\x01' << 8) | 0xff, 0x0707};  // stale bytes after the NUL
  Result<std::string> t = decode_plc_text(words, 13, 0, "serial number");
  ASSERT_TRUE(t.ok()) << "bytes after the NUL are not read: " << t.error().message;
  EXPECT_EQ(*t, "ABC");
  words = {0x2020, 0x2020, 0, 0};
  EXPECT_EQ(*decode_plc_text(words, 13, 0, "serial number"), "") << "spaces only: not given";
}

TEST(PlcText, AByteThatIsNotPrintableAsciiNamesTheWordRegisterAndByte) {
  struct Case {
    std::array<std::uint16_t, 3> words;
    const char* where;
  };
  const Case cases[] = {
      {{('A' << 8) | 'B', ('C' << 8) | 0x09, 0}, "word 14 (holding register 1014), low byte, is 0x09"},  // tab
      {{('A' << 8) | 'B', 0xC384, 0}, "word 14 (holding register 1014), high byte, is 0xC3"},            // UTF-8 Ä
      {{0x7f41, 0, 0}, "word 13 (holding register 1013), high byte, is 0x7F"},                           // DEL
  };
  for (const Case& c : cases) {
    Result<std::string> t = decode_plc_text(c.words, 13, 1000, "serial number");
    ASSERT_FALSE(t.ok()) << c.where;
    EXPECT_EQ(t.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(t.error().message.find("PLC serial number: " + std::string(c.where)), std::string::npos)
        << t.error().message;
  }
}

TEST_F(PlcLinkTest, AWrongBaseAddressIsAnExceptionThatNamesTheKey) {
  ModbusPlcLink link(settings(0));
  ASSERT_TRUE(link.connect().ok());
  Result<PlcRequestWords> req = link.read_request();
  ASSERT_FALSE(req.ok());
  EXPECT_EQ(req.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(req.error().message.find("base_address"), std::string::npos) << req.error().message;
  EXPECT_NE(req.error().message.find("0..36"), std::string::npos)
      << "the whole block in one read: " << req.error().message;
  EXPECT_TRUE(link.connected()) << "an exception reply leaves the link usable";
}

TEST_F(PlcLinkTest, ALinkDroppedByThePlcIsLostThenComesBack) {
  ModbusPlcLink link(settings());
  ASSERT_TRUE(link.connect().ok());
  ASSERT_TRUE(link.read_request().ok());
  sim_->drop_connections();
  Result<PlcRequestWords> lost = link.read_request();
  ASSERT_FALSE(lost.ok());
  EXPECT_EQ(lost.error().code, ErrorCode::kIo);
  EXPECT_NE(lost.error().message.find("tcp:127.0.0.1:" + std::to_string(sim_->port())), std::string::npos)
      << lost.error().message;
  EXPECT_FALSE(link.connected());
  ASSERT_TRUE(link.connect().ok());
  sim_->request(3, 1);
  Result<PlcRequestWords> back = link.read_request();
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->part_number, 3);
}

TEST_F(PlcLinkTest, ARefusedConnectionSaysWhereAndWhatToCheck) {
  sim_->set_refusing(true);
  ModbusPlcLink link(settings());
  Status s = link.connect();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kIo);
  EXPECT_NE(s.error().message.find("PLC at tcp:127.0.0.1:"), std::string::npos) << s.error().message;
  EXPECT_FALSE(link.connected());
  Result<PlcRequestWords> r = link.read_request();
  EXPECT_FALSE(r.ok());
  sim_->set_refusing(false);
  EXPECT_TRUE(link.connect().ok());
}

TEST(PlcSimulator, WaitsForTheServicesWordsWithoutSleeping) {
  auto sim = PlcSimulator::start({});
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  EXPECT_FALSE((*sim)->wait_for_outcome(milliseconds(1)).has_value()) << "nothing written yet";
  PlcLinkSettings s;
  s.link.port = (*sim)->port();
  s.link.response_timeout = milliseconds(2000);
  ModbusPlcLink link(s);
  ASSERT_TRUE(link.connect().ok());
  PlcServiceWords w;
  w.ack = true;
  w.fault = true;
  w.result_code = PlcResultCode::kUnknownPart;
  ASSERT_TRUE(link.write_service_words(w).ok());
  std::optional<PlcServiceWords> seen = (*sim)->wait_for_outcome(milliseconds(60000));
  ASSERT_TRUE(seen.has_value());
  EXPECT_EQ(seen->result_code, PlcResultCode::kUnknownPart);
}

}  // namespace
}  // namespace gaugeloop

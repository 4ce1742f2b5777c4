// The PLC link against the PLC simulator over a real loopback socket: the handshake block
// read and written where the config puts it, a wrong base address, a dropped and a refused link.
#include "acquisition/plc_link.h"

#include <gtest/gtest.h>

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

TEST_F(PlcLinkTest, AWrongBaseAddressIsAnExceptionThatNamesTheKey) {
  ModbusPlcLink link(settings(0));
  ASSERT_TRUE(link.connect().ok());
  Result<PlcRequestWords> req = link.read_request();
  ASSERT_FALSE(req.ok());
  EXPECT_EQ(req.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(req.error().message.find("base_address"), std::string::npos) << req.error().message;
  EXPECT_NE(req.error().message.find("0..12"), std::string::npos) << req.error().message;
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

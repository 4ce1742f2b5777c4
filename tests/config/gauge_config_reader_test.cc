// Gauge config files read without a gauge: defaults kept, and the refusals the integration
// tests (tests/integration/gauge_config_test.cc, with the pymodbus peer) do not already cover.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "config/gauge_config.h"
#include "tests/support/refused.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

using testing::refused;

namespace fs = std::filesystem;

// The smallest map validate() takes: a reading and an angle.
const std::string kMap = "[map.reading]\naddress = 0\ntype = \"INT32\"\n[map.angle]\naddress = 3\ntype = \"UINT32\"\n";

TEST(GaugeConfigReader, KeysLeftOutKeepTheDefaults) {
  ModbusSettings defaults;
  defaults.host = "::1";
  defaults.port = 1600;
  defaults.unit_id = 4;
  defaults.response_timeout = std::chrono::milliseconds(350);
  auto empty = parse_gauge_toml("", "gauge.toml", defaults);
  ASSERT_TRUE(empty.ok()) << empty.error().message;
  EXPECT_EQ(empty->host, "::1");
  EXPECT_EQ(empty->port, 1600);
  EXPECT_EQ(empty->unit_id, 4);
  const RegisterMap simulator;
  EXPECT_EQ(empty->map.reading.address, simulator.reading.address) << "no [map]: the simulator's map";
  EXPECT_EQ(empty->map.latch.ring_address, simulator.latch.ring_address);

  auto some = parse_gauge_toml("[link]\nunit_id = 9\n", "gauge.toml", defaults);
  ASSERT_TRUE(some.ok()) << some.error().message;
  EXPECT_EQ(some->unit_id, 9);
  EXPECT_EQ(some->port, 1600);
  EXPECT_EQ(some->host, "::1");
  EXPECT_EQ(some->response_timeout.count(), 350);
}

// A [map] describes the whole map: what it leaves out is absent, not the simulator's.
TEST(GaugeConfigReader, AMapDescribesTheWholeMap) {
  auto cfg = parse_gauge_toml(kMap, "gauge.toml");
  ASSERT_TRUE(cfg.ok()) << cfg.error().message;
  EXPECT_TRUE(cfg->map.reading.present);
  EXPECT_TRUE(cfg->map.angle.present);
  EXPECT_EQ(cfg->map.angle.address, 3);
  EXPECT_EQ(cfg->map.reading.table, RegisterTable::kInput) << "default register table";
  EXPECT_EQ(cfg->map.reading.order, WordOrder::kABCD) << "default byte order";
  EXPECT_EQ(cfg->map.reading.scale, 1.0);
  EXPECT_FALSE(cfg->map.revolution.present);
  EXPECT_FALSE(cfg->map.sequence.present);
  EXPECT_FALSE(cfg->map.status.present);
  EXPECT_FALSE(cfg->map.latch.present);
}

TEST(GaugeConfigReader, RefusesMistakesNamingFileLineAndKey) {
  struct Case {
    std::string text;
    std::string expected;
  };
  const Case cases[] = {
      {"[links]\nport = 502\n", "gauge.toml:1: key `links`: unknown key; known keys: link, map"},
      {"map = 3\n", "gauge.toml:1: key `map`: expected a table ([map])"},
      {"[link]\nunit_id = 300\n", "gauge.toml:2: key `link.unit_id`: 300 is out of range; allowed [0, 247]"},
      {"[link]\nresponse_timeout_ms = 5\n",
       "gauge.toml:2: key `link.response_timeout_ms`: 5 is out of range; allowed [10, 10000]"},
      {"[link]\ntransport = \"rtu\"\ndevice = \"/dev/ttyS0\"\nparity = \"X\"\n",
       "gauge.toml:4: key `link.parity`: `X` is not one of N, E, O"},
      {"[link]\ntransport = \"udp\"\n", "gauge.toml:2: key `link.transport`: `udp` is not one of tcp, rtu"},
      {kMap + "scale = 1e13\n", "gauge.toml:7: key `map.angle.scale`: 1e+13 is out of range"},
      {kMap + "bits = 3\n",
       "gauge.toml:7: key `map.angle.bits`: unknown key; known keys: register, address, type, byte_order, scale, "
       "offset"},
      {kMap + "[map.status]\naddress = 2\nbyte_order = \"ABCD\"\n", "gauge.toml:9: key `map.status.byte_order`"},
      {kMap + "[map.latch]\nring_address = 4000\nentry_words = 4\ndegree_offset = 2\n",
       "gauge.toml: key `map.latch.count_address` is missing; it is required"},
      {kMap + "[map.latch]\ncount_address = 100\nring_size = 400\nring_size_address = 104\n",
       "gauge.toml:10: key `map.latch.ring_size_address`: give either ring_size or ring_size_address, not both"},
      {kMap + "[map.latch]\ncount_address = 100\nring_size = 400\nring_address = 4000\nentry_words = 126\n",
       "gauge.toml:11: key `map.latch.entry_words`: 126 is out of range; allowed [1, 125]"},
      {kMap + "[map.reading.extra]\n", "gauge.toml:7: key `map.reading.extra`: unknown key"},
  };
  for (const Case& c : cases) EXPECT_TRUE(refused(parse_gauge_toml(c.text, "gauge.toml"), c.expected)) << c.text;
}

TEST(GaugeConfigReader, ReadsAFileWithAByteOrderMarkAndNamesAMissingOne) {
  testing::TempDir dir;
  const fs::path file = dir.write("amp.toml", "\xEF\xBB\xBF[link]\nport = 1700\n");
  auto cfg = read_gauge_file(file);
  ASSERT_TRUE(cfg.ok()) << cfg.error().message;
  EXPECT_EQ(cfg->port, 1700);

  auto missing = read_gauge_file(dir.path() / "absent.toml");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  EXPECT_NE(missing.error().message.find("gauge config " + (dir.path() / "absent.toml").string() + ": no such file"),
            std::string::npos)
      << missing.error().message;

  const fs::path bad = dir.write("bad.toml", "[link]\nport = 0\n");
  EXPECT_TRUE(refused(read_gauge_file(bad), bad.string() + ":2: key `link.port`: 0 is out of range"));
}

}  // namespace
}  // namespace gaugeloop

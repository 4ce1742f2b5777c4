// Gauge config files, and the poller against an independent Modbus server (pymodbus) whose
// register map and word orders differ from the simulator's.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "acquisition/modbus_gauge.h"
#include "acquisition/poller.h"
#include "config/gauge_config.h"
#include "config/toml_reader.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

fs::path example(const char* name) { return fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / "gauges" / name; }

TEST(GaugeConfig, TheSimulatorExampleIsTheDefaultMap) {
  auto cfg = read_gauge_file(example("simulator.toml"));
  ASSERT_TRUE(cfg.ok()) << cfg.error().message;
  const RegisterMap def;
  const RegisterMap& m = cfg->map;
  auto same = [](const FieldSpec& a, const FieldSpec& b) {
    return a.present == b.present && a.table == b.table && a.address == b.address && a.type == b.type &&
           a.order == b.order && a.scale == b.scale && a.offset == b.offset;
  };
  EXPECT_TRUE(same(m.reading, def.reading));
  EXPECT_TRUE(same(m.status, def.status));
  EXPECT_TRUE(same(m.angle, def.angle));
  EXPECT_TRUE(same(m.revolution, def.revolution));
  EXPECT_TRUE(same(m.sequence, def.sequence));
  EXPECT_EQ(m.masks.ready, def.masks.ready);
  EXPECT_EQ(m.masks.probe_missing, def.masks.probe_missing);
  EXPECT_EQ(m.latch.count_address, def.latch.count_address);
  EXPECT_EQ(m.latch.ring_size_address, def.latch.ring_size_address);
  EXPECT_EQ(m.latch.ring_address, def.latch.ring_address);
  EXPECT_EQ(m.latch.status_offset, def.latch.status_offset);
  EXPECT_EQ(cfg->port, 1502);
}

TEST(GaugeConfig, ReadsAnotherAmplifiersMap) {
  auto cfg = read_gauge_file(example("other_amplifier.toml"));
  ASSERT_TRUE(cfg.ok()) << cfg.error().message;
  EXPECT_EQ(cfg->map.reading.type, ValueType::kFloat32);
  EXPECT_EQ(cfg->map.reading.order, WordOrder::kCDAB) << "from [map] byte_order";
  EXPECT_EQ(cfg->map.sequence.order, WordOrder::kDCBA) << "a field's own byte_order wins";
  EXPECT_FALSE(cfg->map.revolution.present);
  EXPECT_EQ(cfg->map.masks.ready, 0x8000);
  EXPECT_EQ(cfg->map.latch.ring_size, 400);
  EXPECT_EQ(cfg->response_timeout.count(), 500);
}

TEST(GaugeConfig, ReadsAnRtuLink) {
  auto cfg = parse_gauge_toml(
      "[link]\ntransport = \"rtu\"\ndevice = \"/dev/ttyS1\"\nbaud = 19200\nparity = \"E\"\nunit_id = 7\n",
      "gauge.toml");
  ASSERT_TRUE(cfg.ok()) << cfg.error().message;
  EXPECT_EQ(cfg->transport, ModbusTransport::kRtu);
  EXPECT_EQ(cfg->device, "/dev/ttyS1");
  EXPECT_EQ(cfg->baud, 19200);
  EXPECT_EQ(cfg->parity, 'E');
  EXPECT_EQ(cfg->unit_id, 7);
  EXPECT_EQ(cfg->stop_bits, 1);
}

struct BadConfig {
  const char* text;
  const char* expected;
};

// The simulator's compact latch ring (docs/gauge.md): the reading alone, the degree implied by
// the latch count, the status from the fault mark counter.
TEST(GaugeConfig, ReadsACompactLatchLayout) {
  const char* text = R"([map]
[map.reading]
address = 0
type = "INT32"
scale = 0.0001
[map.status]
address = 2
over_range_mask = 0x0002
[map.angle]
address = 3
type = "UINT32"
scale = 0.001
[map.latch]
count_address = 100
ring_size_address = 104
ring_address = 4000
entry_words = 2
reading_offset = 0
degree_offset = -1
fault_count_address = 105
fault_status_address = 107
)";
  auto cfg = parse_gauge_toml(text, "compact.toml");
  ASSERT_TRUE(cfg.ok()) << cfg.error().message;
  const LatchSpec& l = cfg->map.latch;
  EXPECT_TRUE(l.degree_implied());
  EXPECT_EQ(l.entry_words, 2);
  EXPECT_EQ(l.status_offset, -1);
  EXPECT_EQ(l.fault_count_address, 105);
  EXPECT_EQ(l.fault_status_address, 107);
  EXPECT_EQ(latched_entries_per_read(cfg->map), 62);
  // Without the fault counter nothing would see an over-range: refused.
  std::string without(text);
  without.erase(without.find("fault_count_address"));
  auto refused = parse_gauge_toml(without, "compact.toml");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("compact.toml: register map: latch: compact entries"), std::string::npos)
      << refused.error().message;
  // Defaults: a labelled layout has no fault counter.
  auto def = read_gauge_file(example("simulator.toml"));
  ASSERT_TRUE(def.ok()) << def.error().message;
  EXPECT_FALSE(def->map.latch.degree_implied());
  EXPECT_EQ(def->map.latch.fault_count_address, -1);
}

// A status word that is 0 when all is well, with a bit for each fault of the amplifier's own.
TEST(GaugeConfig, ReadsAStatusWordWithAnOkValueAndNamedBits) {
  auto cfg = parse_gauge_toml(R"([map]
[map.reading]
address = 0
type = "INT32"
[map.angle]
address = 3
type = "UINT32"
[map.status]
address = 9
ok_value = 0
[map.status.bits]
0 = "lever over-range"
3 = "amplifier not ready"
)",
                              "gauge.toml");
  ASSERT_TRUE(cfg.ok()) << cfg.error().message;
  const StatusMasks& m = cfg->map.masks;
  ASSERT_TRUE(m.ok_value.has_value());
  EXPECT_EQ(*m.ok_value, 0);
  EXPECT_EQ(m.bit_names[0], "lever over-range");
  EXPECT_EQ(m.bit_names[3], "amplifier not ready");
  EXPECT_TRUE(m.bit_names[1].empty());
  EXPECT_EQ(describe_gauge_status(translate_status(0x0009, m), &m.bit_names), "lever over-range, amplifier not ready");
}

// Host names and IPv6 addresses are taken, and a name that does not exist is refused when
// the config is read, not at the first run (".invalid" never resolves, RFC 2606).
TEST(GaugeConfig, ResolvesTheHostWhenRead) {
  for (const char* host : {"localhost", "127.0.0.1", "::1"}) {
    auto cfg = parse_gauge_toml("[link]\nhost = \"" + std::string(host) + "\"\nport = 1502\n", "gauge.toml");
    ASSERT_TRUE(cfg.ok()) << host << ": " << cfg.error().message;
    EXPECT_EQ(cfg->host, host);
  }
  auto bad = parse_gauge_toml("[link]\nhost = \"gauge-amp.invalid\"\n", "gauge.toml");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(bad.error().message.find("gauge.toml:2: key `link.host`: cannot resolve host 'gauge-amp.invalid': "),
            std::string::npos)
      << bad.error().message;
  EXPECT_NE(bad.error().message.find("check the gauge's address"), std::string::npos) << bad.error().message;
}

// The service's [plc] link is read by the same function and says whose address to check.
TEST(GaugeConfig, APlcLinkWithAnUnknownHostNamesThePlc) {
  auto parsed = parse_toml("[plc]\nhost = \"plc.invalid\"\n", "service.toml");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  TomlReader r(*(*parsed)["plc"].as_table(), "service.toml", "plc.");
  ModbusSettings out;
  read_modbus_link(r, ModbusSettings{}, out, "PLC");
  ASSERT_TRUE(r.error.has_value());
  EXPECT_NE(r.error->message.find("service.toml:2: key `plc.host`: cannot resolve host 'plc.invalid': "),
            std::string::npos)
      << r.error->message;
  EXPECT_NE(r.error->message.find("check the PLC's address"), std::string::npos) << r.error->message;
}

TEST(GaugeConfig, RefusesMistakesNamingFileLineAndKey) {
  const BadConfig cases[] = {
      {"[link]\nprot = 502\n", "gauge.toml:2: key `link.prot`: unknown key"},
      {"[map.reading]\naddress = 0\ntype = \"INT64\"\n", "gauge.toml:3: key `map.reading.type`: `INT64` is not one of"},
      {"[map.reading]\naddress = 0\ntype = \"INT32\"\n", "`angle` is required"},
      {"[map]\nbyte_order = \"ABDC\"\n", "gauge.toml:2: key `map.byte_order`"},
      {"[map.status]\naddress = 70000\n", "gauge.toml:2: key `map.status.address`: 70000 is out of range"},
      {"[link\n", "gauge.toml:1"},
      {"[link]\ntransport = \"rtu\"\ndevice = \"/dev/ttyS1\"\nport = 502\n",
       "gauge.toml:4: key `link.port`: a TCP setting in an RTU link"},
      {"[link]\nbaud = 9600\n", "gauge.toml:2: key `link.baud`: a serial setting in a TCP link"},
      {"[link]\ntransport = \"rtu\"\n", "key `link.device` is missing"},
      {"[map.status]\naddress = 9\nok_value = 0\nready_mask = 1\n",
       "gauge.toml:3: key `map.status.ok_value`: give either ok_value (and bits) or the masks"},
      {"[map.status]\naddress = 9\n[map.status.bits]\n0 = \"over-range\"\n",
       "key `map.status.bits`: names status bits of an ok_value status word"},
      {"[map.status]\naddress = 9\nok_value = 0\n[map.status.bits]\n16 = \"x\"\n",
       "gauge.toml:5: key `map.status.bits.16`: a status bit is a number 0 to 15"},
  };
  for (const BadConfig& c : cases) {
    auto cfg = parse_gauge_toml(c.text, "gauge.toml");
    ASSERT_FALSE(cfg.ok()) << c.text;
    EXPECT_EQ(cfg.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(cfg.error().message.find(c.expected), std::string::npos) << cfg.error().message;
  }
}

// The pymodbus peer as a child process: started with its spindle speed and options (see the
// script), its port read from its first line of output, stopped by closing its stdin.
class PymodbusPeer {
 public:
  explicit PymodbusPeer(double speed_rpm, std::vector<std::string> options = {}) {
    int in[2];
    int out[2];
    if (::pipe(in) != 0 || ::pipe(out) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(in[0], 0);
      ::dup2(out[1], 1);
      ::close(in[1]);
      ::close(out[0]);
      const std::string script = std::string(GAUGELOOP_SOURCE_DIR) + "/tests/peers/pymodbus_gauge.py";
      options.insert(options.begin(), {"python3", script, std::to_string(speed_rpm)});
      std::vector<char*> argv;
      for (std::string& o : options) argv.push_back(o.data());
      argv.push_back(nullptr);
      // Debian's interpreter: python3-pymodbus is installed for it, not for others on PATH.
      ::execv("/usr/bin/python3", argv.data());
      ::_exit(127);
    }
    ::close(in[0]);
    ::close(out[1]);
    stdin_ = in[1];
    FILE* f = ::fdopen(out[0], "r");
    char line[128] = {};
    if (f != nullptr && std::fgets(line, sizeof line, f) != nullptr) std::sscanf(line, "port %d", &port_);
    if (f != nullptr) std::fclose(f);
  }
  ~PymodbusPeer() {
    if (stdin_ >= 0) ::close(stdin_);  // the peer exits when its stdin closes
    if (pid_ > 0) {
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
  }
  int port() const { return port_; }

 private:
  pid_t pid_ = -1;
  int stdin_ = -1;
  int port_ = 0;
};

double peer_lift_mm(int deg) {
  const double rad = deg * std::numbers::pi / 180.0;
  return 2.0 + 1.5 * std::cos(rad) + 0.2 * std::sin(3.0 * rad);
}

// Measures through examples/gauges/other_amplifier.toml, changed by `adapt` when given.
Result<MeasuredRun> measure_peer(int port, SamplingMode mode,
                                 const std::function<void(RegisterMap&)>& adapt = nullptr) {
  auto cfg = read_gauge_file(example("other_amplifier.toml"));
  if (!cfg) return cfg.error();
  cfg->port = port;
  if (adapt) adapt(cfg->map);
  ModbusGauge gauge(*cfg);
  PollerSettings ps;
  ps.mode = mode;
  ps.spare_revolutions = 6;
  Poller poller(gauge, ps);
  return poller.measure();
}

// The peer's revolution count (register 16) and its ok-value status code (register 17).
void read_peer_count_and_status_code(RegisterMap& m) {
  m.revolution = FieldSpec{true, RegisterTable::kHolding, 16, ValueType::kUInt16, WordOrder::kABCD, 1.0, 0.0};
  m.status.address = 17;
  m.masks = StatusMasks{};
  m.masks.ok_value = 0;
  m.masks.bit_names[5] = "coil open";
}

TEST(PymodbusPeer, LatchedRunDecodesItsMap) {
  PymodbusPeer peer(60.0);
  ASSERT_GT(peer.port(), 0) << "the pymodbus peer did not start (python3-pymodbus: scripts/install-deps.sh)";
  Result<MeasuredRun> run = measure_peer(peer.port(), SamplingMode::kLatched);
  ASSERT_TRUE(run.ok()) << run.error().message;
  ASSERT_EQ(run->revolutions.size(), 3u);
  // Latched entries are the peer's formula at whole degrees, through float32: 1e-6 mm.
  for (const auto& rev : run->revolutions) {
    for (int d = 0; d < 360; ++d) ASSERT_NEAR(rev.lift_mm[d], peer_lift_mm(d), 1e-6) << "degree " << d;
  }
}

// Live mode: snapshots with no revolution counter (counted from the angle wrapping) and the
// angle in 0.01 deg. Interpolating the peer's lobe (|H''| <= 1.5+1.8 mm/rad^2) linearly between
// polls at most 0.5 deg apart errs by at most 3.3 * (0.5 * pi / 180)^2 / 8 = 3.1e-5 mm, by the
// cubic up to 1 deg far less; the angle's 0.01 deg steps add |H'| * 0.01 deg = 1.5 * 1.75e-4 =
// 2.6e-4 mm, which the cubic's weights (at most about 1.5) could raise to 3.9e-4 mm.
// Tolerance 5e-4 mm.
// Live mode against the peer's spindle turning half a degree a read (its clock is the reads): a
// loaded machine slows the polls and the spindle alike, so no degree is missed for lack of CPU
// (what a late reply costs is the simulator's fault tests' subject, not this map's).
TEST(PymodbusPeer, LiveRunCountsRevolutionsFromTheAngle) {
  PymodbusPeer peer(12.0, {"--degrees-per-read", "0.5"});
  ASSERT_GT(peer.port(), 0) << "the pymodbus peer did not start (python3-pymodbus: scripts/install-deps.sh)";
  Result<MeasuredRun> run = measure_peer(peer.port(), SamplingMode::kLive);
  ASSERT_TRUE(run.ok()) << run.error().message;
  ASSERT_EQ(run->revolutions.size(), 3u);
  for (const auto& rev : run->revolutions) {
    for (int d = 0; d < 360; ++d) ASSERT_NEAR(rev.lift_mm[d], peer_lift_mm(d), 5e-4) << "degree " << d;
  }
}

// A third-party amplifier that moves its revolution count 2 degrees after the angle wraps,
// with a status word that is 0 when all is well: every revolution taken, none lost at a wrap.
TEST(PymodbusPeer, LiveRunTakesARevolutionCountLaggingTheWrap) {
  PymodbusPeer peer(12.0, {"--revolution-lag-deg", "2", "--degrees-per-read", "0.5"});
  ASSERT_GT(peer.port(), 0) << "the pymodbus peer did not start (python3-pymodbus: scripts/install-deps.sh)";
  Result<MeasuredRun> run = measure_peer(peer.port(), SamplingMode::kLive, read_peer_count_and_status_code);
  ASSERT_TRUE(run.ok()) << run.error().message;
  ASSERT_EQ(run->revolutions.size(), 3u);
  for (const auto& rev : run->revolutions) {
    for (int d = 0; d < 360; ++d) ASSERT_NEAR(rev.lift_mm[d], peer_lift_mm(d), 5e-4) << "degree " << d;
  }
}

// Its fault bit 5 from half a revolution on, for good: named by the map's name for it.
TEST(PymodbusPeer, AFaultBitOfItsOwnIsNamed) {
  PymodbusPeer peer(60.0, {"--fault-at-rev", "0.5"});
  ASSERT_GT(peer.port(), 0) << "the pymodbus peer did not start (python3-pymodbus: scripts/install-deps.sh)";
  Result<MeasuredRun> run = measure_peer(peer.port(), SamplingMode::kLive, read_peer_count_and_status_code);
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kIncompleteRun);
  EXPECT_NE(run.error().message.find("gauge status coil open at degrees"), std::string::npos) << run.error().message;
}

// Every register stands still from 1.5 revolutions on while the peer keeps answering: live
// mode names the freeze instead of polling until the run timeout.
TEST(PymodbusPeer, AFrozenAmplifierIsNamedInLiveMode) {
  PymodbusPeer peer(60.0, {"--freeze-at-rev", "1.5"});
  ASSERT_GT(peer.port(), 0) << "the pymodbus peer did not start (python3-pymodbus: scripts/install-deps.sh)";
  Result<MeasuredRun> run = measure_peer(peer.port(), SamplingMode::kLive);
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kGaugeTimeout);
  EXPECT_NE(run.error().message.find("stood still"), std::string::npos) << run.error().message;
  EXPECT_NE(run.error().message.find("sample number stayed at"), std::string::npos) << run.error().message;
}

}  // namespace
}  // namespace gaugeloop

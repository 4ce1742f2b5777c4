// [plant.mqtt] and [plant.central] in the service's configuration: read back, and every
// refusal naming the file, the line and the key.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "config/service_config.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

const fs::path kExamples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
// Lines 1-5; [plant.mqtt] starts on line 6.
const std::string kBase = "[gauge]\n[[part]]\nfile = \"parts/intake_flat.toml\"\n[nc]\ntemplate = \"table.spf\"\n";

class PlantMqttConfigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(dir_.path() / "parts");
    for (const char* name : {"intake_flat.toml", "intake_flat.csv"}) {
      fs::copy_file(kExamples / name, dir_.path() / "parts" / name);
    }
    fs::copy_file(kExamples / "sinumerik" / "cam_table.spf", dir_.path() / "table.spf");
  }
  Result<ServiceConfig> read(const std::string& text) { return read_service_config(dir_.write("svc.toml", text)); }
  std::string at(int line, const std::string& key) const {
    return (dir_.path() / "svc.toml").string() + ":" + std::to_string(line) + ": key `" + key + "`";
  }
  // The message of a refusal, or a failure when the file was taken.
  std::string refusal(const std::string& text) {
    Result<ServiceConfig> c = read(text);
    EXPECT_FALSE(c.ok()) << text;
    if (c.ok()) return {};
    EXPECT_EQ(c.error().code, ErrorCode::kInvalidInput) << c.error().message;
    return c.error().message;
  }
  testing::TempDir dir_;
};

TEST_F(PlantMqttConfigTest, WithoutThePlantTableThereIsNoBroker) {
  Result<ServiceConfig> c = read(kBase);
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_FALSE(c->mqtt.has_value());
}

TEST_F(PlantMqttConfigTest, TheKeysAreReadWithTheirDefaults) {
  Result<ServiceConfig> c =
      read("machine = \"grinder-7\"\n" + kBase + "[plant.mqtt]\nhost = \"broker.plant\"\nsite = \"plant-a\"\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_TRUE(c->mqtt.has_value());
  EXPECT_EQ(c->mqtt->host, "broker.plant");
  EXPECT_EQ(c->mqtt->port, 1883);
  EXPECT_EQ(c->mqtt->site, "plant-a");
  EXPECT_EQ(c->mqtt->client_id, "gaugeloop-grinder-7");
  EXPECT_EQ(c->mqtt->keepalive_s, 30);
  EXPECT_EQ(c->mqtt->max_depth, 100000);
  EXPECT_TRUE(c->mqtt->ca_file.empty());

  const fs::path pw = dir_.write("mqtt-password", "s3cret\n");
  ::chmod(pw.c_str(), 0600);
  dir_.write("ca.pem", "-----BEGIN CERTIFICATE-----\n");
  c = read(kBase +
           "[plant.mqtt]\nhost = \"b\"\nport = 8883\nsite = \"s\"\nclient_id = \"g1\"\nusername = \"grinder\"\n"
           "password_file = \"mqtt-password\"\nca_file = \"ca.pem\"\nkeepalive_s = 60\nmax_depth = 500\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->mqtt->port, 8883);
  EXPECT_EQ(c->mqtt->client_id, "g1");
  EXPECT_EQ(c->mqtt->username, "grinder");
  EXPECT_EQ(c->mqtt->password, "s3cret");
  EXPECT_EQ(c->mqtt->ca_file, dir_.path() / "ca.pem");
  EXPECT_EQ(c->mqtt->keepalive_s, 60);
  EXPECT_EQ(c->mqtt->max_depth, 500);
}

TEST_F(PlantMqttConfigTest, ABadPortNamesFileLineAndKey) {
  const std::string m = refusal(kBase + "[plant.mqtt]\nhost = \"b\"\nsite = \"s\"\nport = 70000\n");
  EXPECT_NE(m.find(at(9, "plant.mqtt.port")), std::string::npos) << m;
}

TEST_F(PlantMqttConfigTest, ASiteThatIsNoTopicLevelNamesFileLineAndKey) {
  for (const char* site : {"plant/a", "plant+", "#", ""}) {
    const std::string m = refusal(kBase + "[plant.mqtt]\nhost = \"b\"\nsite = \"" + site + "\"\n");
    EXPECT_NE(m.find(at(8, "plant.mqtt.site")), std::string::npos) << m;
  }
}

TEST_F(PlantMqttConfigTest, AMachineThatIsNoTopicLevelIsRefusedWithABroker) {
  const std::string m = refusal("machine = \"cell/2\"\n" + kBase + "[plant.mqtt]\nhost = \"b\"\nsite = \"s\"\n");
  EXPECT_NE(m.find(at(1, "machine")), std::string::npos) << m;
  EXPECT_NE(m.find("'/'"), std::string::npos) << m;
}

TEST_F(PlantMqttConfigTest, MissingKeysAnInlinePasswordAndHalfATlsPairAreRefused) {
  EXPECT_NE(refusal(kBase + "[plant.mqtt]\nsite = \"s\"\n").find("plant.mqtt.host"), std::string::npos);
  EXPECT_NE(refusal(kBase + "[plant.mqtt]\nhost = \"b\"\n").find("plant.mqtt.site"), std::string::npos);
  EXPECT_NE(refusal(kBase + "[plant.mqtt]\nhost = \"b\"\nsite = \"s\"\nhots = 1\n").find("hots"), std::string::npos);
  const std::string inline_pw =
      refusal(kBase + "[plant.mqtt]\nhost = \"b\"\nsite = \"s\"\nusername = \"u\"\npassword = \"p\"\n");
  EXPECT_NE(inline_pw.find(at(10, "plant.mqtt.password")), std::string::npos) << inline_pw;
  EXPECT_NE(inline_pw.find("password_file"), std::string::npos) << inline_pw;
  const std::string half = refusal(kBase + "[plant.mqtt]\nhost = \"b\"\nsite = \"s\"\ncert_file = \"c.pem\"\n");
  EXPECT_NE(half.find(at(9, "plant.mqtt.cert_file")), std::string::npos) << half;
  const fs::path pw = dir_.write("open-password", "p\n");
  ::chmod(pw.c_str(), 0644);
  const std::string open = refusal(
      kBase + "[plant.mqtt]\nhost = \"b\"\nsite = \"s\"\nusername = \"u\"\npassword_file = \"open-password\"\n");
  EXPECT_NE(open.find(at(10, "plant.mqtt.password_file")), std::string::npos) << open;
  EXPECT_NE(open.find("can be read by any user"), std::string::npos) << open;
}

// ---- [plant.central] ----

using PlantCentralConfigTest = PlantMqttConfigTest;

TEST_F(PlantCentralConfigTest, TheKeysAreReadWithTheirDefaults) {
  Result<ServiceConfig> c = read(kBase);
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_FALSE(c->central.has_value()) << "no table, no sync";

  c = read(kBase + "[plant.central]\nurl = \"postgresql://gaugeloop@central:5432/plant\"\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_TRUE(c->central.has_value());
  EXPECT_EQ(c->central->url, "postgresql://gaugeloop@central:5432/plant");
  EXPECT_EQ(c->central->interval, std::chrono::seconds(60));
  EXPECT_EQ(c->central->batch_size, 200);
  EXPECT_FALSE(c->central->programs) << "program texts only when asked";
  EXPECT_FALSE(c->central->per_degree) << "per-degree tables only when asked";
  EXPECT_FALSE(c->mqtt.has_value()) << "the central history needs no broker";

  c = read(kBase +
           "[plant.central]\nurl = \"postgresql://gaugeloop@central/plant?passfile=/etc/gaugeloop/pgpass\"\n"
           "interval_s = 600\nbatch_size = 50\nprograms = true\nper_degree = true\n[plant.mqtt]\nhost = \"b\"\nsite = "
           "\"s\"\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_TRUE(c->central->programs);
  EXPECT_TRUE(c->central->per_degree);
  EXPECT_EQ(c->central->interval, std::chrono::seconds(600));
  EXPECT_EQ(c->central->batch_size, 50);
  EXPECT_TRUE(c->mqtt.has_value());
}

TEST_F(PlantCentralConfigTest, ABadUrlAPasswordInItAndBadNumbersNameFileLineAndKey) {
  const std::string no_url = refusal(kBase + "[plant.central]\ninterval_s = 60\n");
  EXPECT_NE(no_url.find("plant.central.url"), std::string::npos) << no_url;
  const std::string file = refusal(kBase + "[plant.central]\nurl = \"/var/lib/gaugeloop/runs.sqlite\"\n");
  EXPECT_NE(file.find(at(7, "plant.central.url")), std::string::npos) << file;
  EXPECT_NE(file.find("postgresql://"), std::string::npos) << file;
  const std::string no_db = refusal(kBase + "[plant.central]\nurl = \"postgresql://central:5432\"\n");
  EXPECT_NE(no_db.find("database name"), std::string::npos) << no_db;
  for (const std::string& with_password : {std::string("postgresql://gaugeloop:s3cret@central/plant"),
                                           std::string("postgresql://gaugeloop@central/plant?password=s3cret")}) {
    const std::string m = refusal(kBase + "[plant.central]\nurl = \"" + with_password + "\"\n");
    EXPECT_NE(m.find(at(7, "plant.central.url")), std::string::npos) << m;
    EXPECT_NE(m.find("passfile"), std::string::npos) << m;
    EXPECT_EQ(m.find("s3cret"), std::string::npos) << "never print the password: " << m;
  }
  const std::string often = refusal(kBase + "[plant.central]\nurl = \"postgresql://central/plant\"\ninterval_s = 5\n");
  EXPECT_NE(often.find(at(8, "plant.central.interval_s")), std::string::npos) << often;
  const std::string batch = refusal(kBase + "[plant.central]\nurl = \"postgresql://central/plant\"\nbatch_size = 0\n");
  EXPECT_NE(batch.find(at(8, "plant.central.batch_size")), std::string::npos) << batch;
  const std::string typo = refusal(kBase + "[plant.central]\nurl = \"postgresql://central/plant\"\nintervall_s = 60\n");
  EXPECT_NE(typo.find("intervall_s"), std::string::npos) << typo;
  const std::string other = refusal(kBase + "[plant.cental]\nurl = \"postgresql://central/plant\"\n");
  EXPECT_NE(other.find("cental"), std::string::npos) << other;
}

// [http] history: the file by default; `central` reads the lists from [plant.central]'s history
// and is refused without one, naming the key.
TEST_F(PlantCentralConfigTest, TheHttpHistoryIsTheFileOrTheCentralHistoryOfPlantCentral) {
  Result<ServiceConfig> c = read(kBase + "[http]\nport = 8080\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_TRUE(c->http.has_value());
  EXPECT_EQ(c->http->history_url, "") << "the service's own file";
  c = read(kBase + "[http]\nhistory = \"central\"\n[plant.central]\nurl = \"postgresql://gaugeloop@central/plant\"\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->http->history_url, "postgresql://gaugeloop@central/plant");
  c = read(kBase + "[http]\nhistory = \"local\"\n[plant.central]\nurl = \"postgresql://gaugeloop@central/plant\"\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->http->history_url, "") << "synced, but the pages read the file";

  const std::string none = refusal(kBase + "[http]\nhistory = \"central\"\n");
  EXPECT_NE(none.find(at(7, "http.history")), std::string::npos) << none;
  EXPECT_NE(none.find("[plant.central]"), std::string::npos) << none;
  const std::string other = refusal(kBase + "[http]\nhistory = \"plant\"\n");
  EXPECT_NE(other.find(at(7, "http.history")), std::string::npos) << other;
  EXPECT_NE(other.find("local"), std::string::npos) << other;
}

}  // namespace
}  // namespace gaugeloop

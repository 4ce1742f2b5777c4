// The service configuration's network sides: [http] (the token, its file and strength, TLS),
// [plc], and [plant] (MQTT with its password and TLS files, the central history). Every file
// holding a secret is checked for who may read it. Every message with file, line and key.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <string>

#include "config/gauge_config.h"
#include "config/service_config_internal.h"
#include "plant/central_history.h"
#include "plant/plant_messages.h"

namespace gaugeloop::config_internal {
namespace {

// A file holding a secret (the token, the TLS private key) that the service reads: nobody
// but its owner and group may write it, nobody outside its group may read it, and its owner is
// root or the user the service runs as, so no other account can swap in a token of its own.
// The documented layout is root:gaugeloop 0640.
Status check_secret_file(const TomlReader& r, std::string_view key, const fs::path& path, const std::string& what) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) {
    const int err = errno;
    return make_error(err == ENOENT ? ErrorCode::kNotFound : ErrorCode::kInvalidInput,
                      r.where(key) + ": " + what + " " + path.string() + ": " + std::strerror(err));
  }
  // Whoever can change a link, or replace a file in its directory, chooses the secret.
  if (S_ISLNK(st.st_mode)) {
    return make_error(ErrorCode::kInvalidInput, r.where(key) + ": " + what + " " + path.string() +
                                                    " is a symbolic link: whoever can change the link chooses what is "
                                                    "read; give the file itself");
  }
  struct stat dir {};
  const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
  if (::stat(parent.c_str(), &dir) == 0 && (dir.st_mode & S_IWOTH) != 0 && (dir.st_mode & S_ISVTX) == 0) {
    return make_error(ErrorCode::kInvalidInput, r.where(key) + ": " + what + " " + path.string() +
                                                    " lies in a directory any user can write (" + parent.string() +
                                                    "), where anyone can replace it; keep it in /etc/gaugeloop");
  }
  char mode[8];
  std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
  const std::string fix = "; run `chmod 0640 " + path.string() + "; chown root:gaugeloop " + path.string() +
                          "` (gaugeloop being the service's group)";
  std::string wrong;
  if ((st.st_mode & S_IWOTH) != 0) {
    wrong = "can be written by any user";
  } else if ((st.st_mode & S_IWGRP) != 0) {
    wrong = "can be written by its group";
  } else if ((st.st_mode & S_IROTH) != 0) {
    wrong = "can be read by any user";
  } else if ((st.st_mode & S_IXOTH) != 0) {
    wrong = "gives any user access";
  }
  if (!wrong.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      r.where(key) + ": " + what + " " + path.string() + " " + wrong + " (mode " + mode + ")" + fix);
  }
  if (st.st_uid != 0 && st.st_uid != ::geteuid()) {
    return make_error(ErrorCode::kInvalidInput, r.where(key) + ": " + what + " " + path.string() + " is owned by uid " +
                                                    std::to_string(st.st_uid) +
                                                    ", neither root nor the user this service runs as (uid " +
                                                    std::to_string(::geteuid()) + "), who could replace it" + fix);
  }
  return {};
}

// How many bits an attacker must guess, estimated from the length and the character classes
// used: hex (digits with a-f, or with A-F, and nothing else) counts 4 bits a character;
// otherwise each class present adds its size to the alphabet (digits 10, lower 26, upper 26,
// anything else 32) and each character counts log2 of that. An upper bound for a token a
// person made up, exact for one drawn at random from that alphabet.
double estimated_token_bits(std::string_view token) {
  auto all = [token](auto in_class) { return std::all_of(token.begin(), token.end(), in_class); };
  auto any = [token](auto in_class) { return std::any_of(token.begin(), token.end(), in_class); };
  auto digit = [](char c) { return c >= '0' && c <= '9'; };
  auto lower = [](char c) { return c >= 'a' && c <= 'z'; };
  auto upper = [](char c) { return c >= 'A' && c <= 'Z'; };
  auto other = [&](char c) { return !digit(c) && !lower(c) && !upper(c); };
  auto hex_letter = [](char c) { return (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F'); };
  const bool hex = any(hex_letter) && (all([&](char c) { return digit(c) || (c >= 'a' && c <= 'f'); }) ||
                                       all([&](char c) { return digit(c) || (c >= 'A' && c <= 'F'); }));
  const double alphabet = hex ? 16.0
                              : (any(digit) ? 10.0 : 0.0) + (any(lower) ? 26.0 : 0.0) + (any(upper) ? 26.0 : 0.0) +
                                    (any(other) ? 32.0 : 0.0);
  return alphabet > 1.0 ? static_cast<double>(token.size()) * std::log2(alphabet) : 0.0;
}

// A token must be hard to guess: at least kMinTokenChars characters, at least
// kMinTokenDistinctChars different ones (sixteen `a`, or `abab...`, are refused), and an
// estimated kMinTokenBits bits (estimated_token_bits).
constexpr size_t kMinTokenChars = 32;
constexpr size_t kMinTokenDistinctChars = 8;
constexpr double kMinTokenBits = 128.0;

Status check_token_strength(const TomlReader& hr, std::string_view key, const std::string& token) {
  const std::string advice = "; make one with `gaugeloop token new FILE` (256 random bits)";
  if (token.size() < kMinTokenChars) {
    return make_error(ErrorCode::kInvalidInput, hr.where(key) + ": the token has " + std::to_string(token.size()) +
                                                    " characters, fewer than " + std::to_string(kMinTokenChars) +
                                                    ": too easy to guess" + advice);
  }
  const std::set<char> distinct(token.begin(), token.end());
  if (distinct.size() < kMinTokenDistinctChars) {
    return make_error(ErrorCode::kInvalidInput,
                      hr.where(key) + ": the token uses only " + std::to_string(distinct.size()) +
                          " different characters (at least " + std::to_string(kMinTokenDistinctChars) +
                          "): too easy to guess" + advice);
  }
  if (const double bits = estimated_token_bits(token); bits < kMinTokenBits) {
    return make_error(ErrorCode::kInvalidInput, hr.where(key) + ": the token holds about " +
                                                    std::to_string(static_cast<int>(bits)) + " bits, fewer than " +
                                                    std::to_string(static_cast<int>(kMinTokenBits)) +
                                                    ": too easy to guess; make it longer" + advice);
  }
  for (char c : token) {
    if (static_cast<unsigned char>(c) <= ' ' || c == 0x7f) {
      return make_error(ErrorCode::kInvalidInput,
                        hr.where(key) +
                            ": the token holds a blank or control character, which no HTTP client sends "
                            "in an Authorization header" +
                            advice);
    }
  }
  return {};
}

// The token read from [http] token_file: the file checked (check_secret_file), its text
// without trailing blanks, not empty.
Result<std::string> read_token_file(const TomlReader& hr, const ConfigFile& f, const std::string& token_file) {
  const fs::path path = f.resolve(token_file);
  if (Status s = check_secret_file(hr, "token_file", path, "HTTP token file"); !s) return s.error();
  Result<std::string> text = read_text(path, "HTTP token file");
  if (!text) return hr.at_key("token_file", text.error());
  std::string token = *text;
  while (!token.empty() && (token.back() == '\n' || token.back() == '\r' || token.back() == ' ')) token.pop_back();
  if (token.empty()) return make_error(ErrorCode::kInvalidInput, hr.where("token_file") + ": the file is empty");
  return token;
}

// [http] tls_cert and tls_key: both or neither, each a readable regular file; the key is a
// secret, checked like the token file.
Status read_tls_keys(const TomlReader& hr, const ConfigFile& f, const std::string& cert, const std::string& key,
                     HttpSettings& hs) {
  if (cert.empty() != key.empty()) {
    return make_error(ErrorCode::kInvalidInput, hr.where(cert.empty() ? "tls_key" : "tls_cert") +
                                                    ": give both tls_cert and tls_key (PEM files) for HTTPS, or "
                                                    "neither for plain HTTP");
  }
  if (cert.empty()) return {};
  hs.tls_cert = f.resolve(cert);
  hs.tls_key = f.resolve(key);
  if (Status s = check_secret_file(hr, "tls_key", hs.tls_key, "TLS private key"); !s) return s;
  Result<std::string> cert_text = read_regular_file(hs.tls_cert, "TLS certificate");
  if (!cert_text) return hr.at_key("tls_cert", cert_text.error());
  Result<std::string> key_text = read_regular_file(hs.tls_key, "TLS private key");
  if (!key_text) return hr.at_key("tls_key", key_text.error());
  return {};
}

}  // namespace

// [http]: address, token and TLS files of the HTTP API, and the history its lists read (the
// service's file, or `central`: the [plant.central] history); absent table, no API.
Result<std::optional<HttpSettings>> read_http_table(TomlReader& top, const ConfigFile& f,
                                                    const std::optional<CentralSyncSettings>& central) {
  const toml::table* t = top.subtable("http");
  if (t == nullptr) return std::optional<HttpSettings>();
  TomlReader hr(*t, f.source, "http.");
  hr.allow_only({"host", "port", "token", "token_file", "allow_inline_token", "tls_cert", "tls_key", "history"});
  HttpSettings hs;
  const std::string history = hr.text("history", "local");
  if (hr.error) return *hr.error;
  if (history != "local" && history != "central") {
    return make_error(ErrorCode::kInvalidInput, hr.where("history") + ": '" + history +
                                                    "' is not one of local (this grinder's file) and central (the "
                                                    "plant's history of [plant.central])");
  }
  if (history == "central") {
    if (!central) {
      return make_error(ErrorCode::kInvalidInput,
                        hr.where("history") +
                            ": central needs the central history's URL: give [plant.central] url = "
                            "\"postgresql://USER@HOST/DATABASE\", or history = \"local\"");
    }
    hs.history_url = central->url;
  }
  hs.host = hr.text("host", "127.0.0.1");
  hs.port = static_cast<int>(hr.integer("port", 8080, 0, 65535));
  hs.token = hr.text("token", "");
  const bool allow_inline = hr.flag("allow_inline_token", false);
  const std::string token_file = hr.text("token_file", "");
  const std::string tls_cert = hr.text("tls_cert", "");
  const std::string tls_key = hr.text("tls_key", "");
  if (hr.error) return *hr.error;
  if (!hs.token.empty() && !token_file.empty()) {
    return make_error(ErrorCode::kInvalidInput, hr.where("token_file") + ": give token or token_file, not both");
  }
  if (!hs.token.empty() && !allow_inline) {
    return make_error(ErrorCode::kInvalidInput,
                      hr.where("token") +
                          ": a token written in the config is refused: the config is often readable by every user "
                          "and copied around (backups, tickets, other machines). Put it in a file only root and the "
                          "service's group can read (`gaugeloop token new /etc/gaugeloop/token`) and give "
                          "`token_file = \"/etc/gaugeloop/token\"`; or, for a test bench, `allow_inline_token = "
                          "true`");
  }
  if (!token_file.empty()) {
    Result<std::string> token = read_token_file(hr, f, token_file);
    if (!token) return token.error();
    hs.token = std::move(*token);
  }
  if (!hs.token.empty()) {
    if (Status s = check_token_strength(hr, token_file.empty() ? "token" : "token_file", hs.token); !s) {
      return s.error();
    }
  }
  if (Status s = read_tls_keys(hr, f, tls_cert, tls_key, hs); !s) return s.error();
  return std::optional<HttpSettings>(std::move(hs));
}

// [plc]: the link settings of a gauge config's [link], plus where the block is and how often
// it is polled; absent table, no PLC trigger.
Result<std::optional<PlcSettings>> read_plc_table(TomlReader& top, const ConfigFile& f) {
  const toml::table* t = top.subtable("plc");
  if (t == nullptr) return std::optional<PlcSettings>();
  TomlReader plr(*t, f.source, "plc.");
  plr.allow_only({"transport", "host", "port", "device", "baud", "parity", "data_bits", "stop_bits", "unit_id",
                  "response_timeout_ms", "base_address", "poll_interval_ms", "part_temperature"});
  PlcSettings ps;
  ModbusSettings defaults;
  defaults.port = 502;
  read_modbus_link(plr, defaults, ps.link.link, "PLC");
  ps.link.part_temperature = plr.flag("part_temperature", false);
  const int words = ps.link.part_temperature ? plc_registers::kBlockWordsWithTemperature : plc_registers::kBlockWords;
  ps.link.base_address = static_cast<int>(plr.integer("base_address", 0, 0, 65536 - words));
  ps.poll_interval = std::chrono::milliseconds(plr.integer("poll_interval_ms", 100, 10, 10000));
  if (plr.error) return *plr.error;
  return std::optional<PlcSettings>(std::move(ps));
}

namespace {

// [plant.mqtt] password_file: checked like the token file (a secret), its text without
// trailing blanks, not empty.
Result<std::string> read_password_file(const TomlReader& mr, const ConfigFile& f, const std::string& file) {
  const fs::path path = f.resolve(file);
  if (Status s = check_secret_file(mr, "password_file", path, "broker password file"); !s) return s.error();
  Result<std::string> text = read_text(path, "broker password file");
  if (!text) return mr.at_key("password_file", text.error());
  std::string password = *text;
  while (!password.empty() && (password.back() == '\n' || password.back() == '\r' || password.back() == ' ')) {
    password.pop_back();
  }
  if (password.empty()) return make_error(ErrorCode::kInvalidInput, mr.where("password_file") + ": the file is empty");
  return password;
}

// [plant.mqtt] ca_file, cert_file, key_file: TLS when ca_file is set; a client certificate
// needs both cert_file and key_file (the key a secret, checked like the token file).
Status read_mqtt_tls(const TomlReader& mr, const ConfigFile& f, const std::string& ca, const std::string& cert,
                     const std::string& key, MqttSettings& m) {
  if (cert.empty() != key.empty()) {
    return make_error(ErrorCode::kInvalidInput, mr.where(cert.empty() ? "key_file" : "cert_file") +
                                                    ": give both cert_file and key_file (PEM files) for a client "
                                                    "certificate, or neither");
  }
  if (!cert.empty() && ca.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      mr.where("cert_file") +
                          ": a client certificate is sent over TLS only; give ca_file too (the CA "
                          "that signed the broker's certificate)");
  }
  if (ca.empty()) return {};
  m.ca_file = f.resolve(ca);
  Result<std::string> ca_text = read_regular_file(m.ca_file, "broker CA file");
  if (!ca_text) return mr.at_key("ca_file", ca_text.error());
  if (cert.empty()) return {};
  m.cert_file = f.resolve(cert);
  m.key_file = f.resolve(key);
  Result<std::string> cert_text = read_regular_file(m.cert_file, "broker client certificate");
  if (!cert_text) return mr.at_key("cert_file", cert_text.error());
  if (Status s = check_secret_file(mr, "key_file", m.key_file, "broker client key"); !s) return s;
  Result<std::string> key_text = read_regular_file(m.key_file, "broker client key");
  if (!key_text) return mr.at_key("key_file", key_text.error());
  return {};
}

// [plant.mqtt]: the plant's broker. The machine name becomes a topic level, so it is checked
// here too.
Result<MqttSettings> read_plant_mqtt(const TomlReader& top, const toml::table& t, const ConfigFile& f,
                                     const std::string& machine) {
  TomlReader mr(t, f.source, "plant.mqtt.");
  mr.allow_only({"host", "port", "site", "client_id", "username", "password", "password_file", "ca_file", "cert_file",
                 "key_file", "keepalive_s", "max_depth"});
  MqttSettings m;
  m.host = mr.text("host", std::nullopt);
  m.port = static_cast<int>(mr.integer("port", 1883, 1, 65535));
  m.site = mr.text("site", std::nullopt);
  m.client_id = mr.text("client_id", "gaugeloop-" + machine);
  m.username = mr.text("username", "");
  const std::string password_file = mr.text("password_file", "");
  const std::string ca = mr.text("ca_file", "");
  const std::string cert = mr.text("cert_file", "");
  const std::string key = mr.text("key_file", "");
  m.keepalive_s = static_cast<int>(mr.integer("keepalive_s", 30, 5, 3600));
  m.max_depth = mr.integer("max_depth", 100000, 1, 100000000);
  if (mr.error) return *mr.error;
  if (mr.has("password")) {
    return make_error(ErrorCode::kInvalidInput,
                      mr.where("password") +
                          ": a password written in the config is refused: the config is often readable by every user "
                          "and copied around. Put it in a file only root and the service's group can read and give "
                          "`password_file = \"/etc/gaugeloop/mqtt-password\"`");
  }
  if (m.host.empty()) return make_error(ErrorCode::kInvalidInput, mr.where("host") + ": is empty; name the broker");
  if (Status s = check_topic_level(mr.where("site"), m.site); !s) return s.error();
  if (Status s = check_topic_level(top.where("machine") + " (a level of the broker's topics)", machine); !s) {
    return s.error();
  }
  if (m.client_id.empty() || m.client_id.size() > 128) {
    return make_error(ErrorCode::kInvalidInput,
                      mr.where("client_id") + ": give 1 to 128 characters, unique among the broker's clients");
  }
  if (!password_file.empty()) {
    if (m.username.empty()) {
      return make_error(ErrorCode::kInvalidInput,
                        mr.where("password_file") + ": a password needs a username; give username too");
    }
    Result<std::string> password = read_password_file(mr, f, password_file);
    if (!password) return password.error();
    m.password = std::move(*password);
  }
  if (Status s = read_mqtt_tls(mr, f, ca, cert, key, m); !s) return s.error();
  return m;
}

// [plant.central]: the central history the service syncs its runs into. The URL's password,
// like the broker's, never stands in the config: libpq reads it from a passfile.
Result<CentralSyncSettings> read_plant_central(const toml::table& t, const ConfigFile& f) {
  TomlReader cr(t, f.source, "plant.central.");
  cr.allow_only({"url", "interval_s", "batch_size", "programs", "per_degree"});
  CentralSyncSettings c;
  c.url = cr.text("url", std::nullopt);
  c.interval = std::chrono::seconds(cr.integer("interval_s", 60, 10, 86400));
  c.batch_size = static_cast<int>(cr.integer("batch_size", 200, 1, 10000));
  c.programs = cr.flag("programs", false);
  c.per_degree = cr.flag("per_degree", false);
  if (cr.error) return *cr.error;
  Result<CentralUrl> url = parse_central_url(c.url);
  if (!url) return make_error(ErrorCode::kInvalidInput, cr.where("url") + ": " + url.error().message);
  if (url->has_password) {
    return make_error(ErrorCode::kInvalidInput,
                      cr.where("url") +
                          ": a password written in the config is refused: the config is often readable by every user "
                          "and copied around. Put it in a file in PostgreSQL's passfile form "
                          "(HOST:PORT:DATABASE:USER:PASSWORD, mode 0600, owned by the service's user) and name it in "
                          "the URL: postgresql://gaugeloop@central/plant?passfile=/etc/gaugeloop/pgpass");
  }
  return c;
}

}  // namespace

// [plant]: the plant's broker ([plant.mqtt]) and central history ([plant.central]), each
// optional. No broker: the outbox stays disabled; no central history: `gaugeloop plant sync`
// (from a timer) copies the runs, or nothing does.
Status read_plant_table(TomlReader& top, const ConfigFile& f, ServiceConfig& c) {
  const toml::table* plant = top.subtable("plant");
  if (plant == nullptr) return {};
  TomlReader pr(*plant, f.source, "plant.");
  pr.allow_only({"mqtt", "central"});
  const toml::table* mqtt = pr.subtable("mqtt");
  const toml::table* central = pr.subtable("central");
  if (pr.error) return *pr.error;
  if (mqtt != nullptr) {
    Result<MqttSettings> m = read_plant_mqtt(top, *mqtt, f, c.machine);
    if (!m) return m.error();
    c.mqtt = std::move(*m);
  }
  if (central != nullptr) {
    Result<CentralSyncSettings> sync = read_plant_central(*central, f);
    if (!sync) return sync.error();
    c.central = std::move(*sync);
  }
  return {};
}

}  // namespace gaugeloop::config_internal

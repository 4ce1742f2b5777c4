// What the HTTP API's routes share: answers, query and body parsing, files.
#include "service/http_support.h"

#include <stdlib.h>

#include <utility>

#include "core/text_file.h"

namespace gaugeloop::http_detail {

void send_json(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_content(body.dump(2, ' ', false, json::error_handler_t::replace) + "\n", "application/json");
}

void send_error(httplib::Response& res, int status, const std::string& message) {
  send_json(res, status, json{{"error", message}});
}

int http_status_for(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidInput:
      return 400;
    case ErrorCode::kNotFound:
      return 404;
    case ErrorCode::kRefused:
      return 409;
    case ErrorCode::kStorage:
    case ErrorCode::kIo:
      return 503;
    case ErrorCode::kGaugeUnreachable:
    case ErrorCode::kGaugeTimeout:
    case ErrorCode::kGaugeProtocol:
    case ErrorCode::kIncompleteRun:
      return 502;
    case ErrorCode::kInternal:
      return 500;
  }
  return 500;
}

void send_error(httplib::Response& res, const Error& e) { send_error(res, http_status_for(e.code), e.message); }

void close_after_answer(const httplib::Request& req, httplib::Response& res) {
  if (req.get_header_value("Connection") != "close") res.set_header("Connection", "close");
  auto text = std::make_shared<const std::string>(std::move(res.body));
  res.body.clear();
  std::string type = res.get_header_value("Content-Type");
  if (text->empty()) {
    // set_content_provider needs a length: an empty answer is one newline.
    text = std::make_shared<const std::string>("\n");
    type = "text/plain";
  }
  res.set_content_provider(text->size(), type, [text](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
    sink.write(text->data() + offset, length);
    return false;  // ends the connection after the answer
  });
}

Error bad_request(std::string message) { return make_error(ErrorCode::kInvalidInput, std::move(message)); }

Result<RunQuery> run_query(const Query& q, int default_limit) {
  RunQuery out;
  out.part = q.text("part");
  out.machine = q.text("machine");
  Result<int> lobe = q.integer("lobe", 0, 1, kMaxLobe);
  if (!lobe) return lobe.error();
  out.lobe = *lobe;
  Result<int> limit = q.integer("limit", default_limit, 1, kMaxLimit);
  if (!limit) return limit.error();
  out.limit = *limit;
  Result<std::string> since = q.time("since", false);
  if (!since) return since.error();
  out.since_utc = *since;
  Result<std::string> until = q.time("until", true);
  if (!until) return until.error();
  out.until_utc = *until;
  return out;
}

Result<std::int64_t> path_id(const std::string& text, const std::string& what) {
  std::int64_t id = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), id);
  const bool whole = !text.empty() && end == text.data() + text.size();
  if (whole && ec == std::errc() && id >= 1) return id;
  // A number, but 0, negative or beyond 64 bits.
  if (whole) return bad_request(what + " " + text + " is out of range; ids are whole numbers from 1");
  return bad_request(what + " '" + text + "' is not a number; ids are whole numbers from 1");
}

Result<json> body_object(const std::string& text, const std::vector<std::string>& known, const char* example) {
  const std::string hint = std::string("; send a JSON object such as ") + example;
  if (text.empty()) return bad_request("the request body is empty" + hint);
  json body;
  try {
    body = json::parse(text);
  } catch (const json::parse_error& e) {
    // what(): "[json.exception.parse_error.101] parse error at line 1, column 2: ..."
    std::string why = e.what();
    if (const std::size_t at = why.find("] "); at != std::string::npos) why = why.substr(at + 2);
    return bad_request("the request body is not JSON: " + why + hint);
  }
  if (!body.is_object())
    return bad_request(std::string("the request body must be a JSON object, not ") + body.type_name() + hint);
  for (const auto& [key, value] : body.items()) {
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
      return bad_request("unknown field `" + key + "` in the request body; it takes " + list);
    }
  }
  return body;
}

Result<std::string> string_field(const json& body, const std::string& name, bool required) {
  const auto it = body.find(name);
  if (it == body.end() || it->is_null()) {
    if (required) return bad_request("the request body needs `" + name + "` (a string)");
    return std::string();
  }
  if (!it->is_string()) return bad_request("`" + name + "` must be a string, not " + std::string(it->type_name()));
  std::string v = it->get<std::string>();
  if (required && v.empty()) return bad_request("`" + name + "` must not be empty");
  return v;
}

Result<int> int_field(const json& body, const std::string& name, int min, int max) {
  const auto it = body.find(name);
  if (it == body.end() || it->is_null()) return bad_request("the request body needs `" + name + "` (a whole number)");
  const bool whole =
      it->is_number_integer() || (it->is_number_float() && std::floor(it->get<double>()) == it->get<double>());
  if (!whole || it->get<double>() < min || it->get<double>() > max) {
    return bad_request("`" + name + "` must be a whole number from " + std::to_string(min) + " to " +
                       std::to_string(max) + ", not " + it->dump(-1, ' ', false, json::error_handler_t::replace));
  }
  return static_cast<int>(it->get<double>());
}

Result<bool> bool_field(const json& body, const std::string& name) {
  const auto it = body.find(name);
  if (it == body.end() || it->is_null()) return false;
  if (!it->is_boolean())
    return bad_request("`" + name + "` must be true or false, not " + std::string(it->type_name()));
  return it->get<bool>();
}

Result<std::optional<double>> number_field(const json& body, const std::string& name) {
  const auto it = body.find(name);
  if (it == body.end() || it->is_null()) return std::optional<double>();
  if (!it->is_number()) {
    return bad_request("`" + name + "` must be a number, not " +
                       it->dump(-1, ' ', false, json::error_handler_t::replace));
  }
  return std::optional<double>(it->get<double>());
}

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

bool is_json_media_type(std::string_view type) {
  type = type.substr(0, type.find(';'));
  while (!type.empty() && (type.back() == ' ' || type.back() == '\t')) type.remove_suffix(1);
  while (!type.empty() && (type.front() == ' ' || type.front() == '\t')) type.remove_prefix(1);
  return iequals(type, "application/json");
}

bool same_secret(std::string_view given, std::string_view expected) {
  unsigned char diff = given.size() == expected.size() ? 0 : 1;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const char g = i < given.size() ? given[i] : '\0';
    diff = static_cast<unsigned char>(diff | (static_cast<unsigned char>(g) ^ static_cast<unsigned char>(expected[i])));
  }
  return diff == 0;
}

namespace {

// ---- Pictures and files ----

// A directory of its own under the system's temporary directory, removed with everything in it
// when this ends: the report and trend writers write files, and two requests must not share one.
class ScratchDir {
 public:
  static Result<ScratchDir> make() {
    std::error_code ec;
    std::string pattern = (fs::temp_directory_path(ec) / "gaugeloop-http-XXXXXX").string();
    if (ec || ::mkdtemp(pattern.data()) == nullptr) {
      return make_error(ErrorCode::kIo, "cannot make a temporary directory for the file (" + pattern +
                                            "); check that TMPDIR names a writable directory");
    }
    return ScratchDir(fs::path(pattern));
  }
  ScratchDir(ScratchDir&& other) noexcept : path_(std::exchange(other.path_, fs::path())) {}
  ScratchDir& operator=(ScratchDir&&) = delete;
  ~ScratchDir() {
    std::error_code ec;
    if (!path_.empty()) fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  explicit ScratchDir(fs::path path) : path_(std::move(path)) {}
  fs::path path_;
};

}  // namespace

Result<std::string> file_written_by(const std::function<Status(const fs::path&)>& write, const std::string& name) {
  Result<ScratchDir> dir = ScratchDir::make();
  if (!dir) return dir.error();
  const fs::path out = dir->path() / name;
  if (Status s = write(out); !s) return s.error();
  return read_regular_file(out, "the file written for the answer");
}

}  // namespace gaugeloop::http_detail

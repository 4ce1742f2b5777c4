// An HTTP answer as the API tests look at it: status, body, content type, headers and the body
// parsed as JSON when it is JSON. Include it after every other header: httplib brings
// <resolv.h>, whose `res` macro breaks Eigen's headers.
#pragma once

#include <httplib.h>

#include <nlohmann/json.hpp>
#include <string>

namespace gaugeloop::testing {

struct HttpAnswer {
  int status = -1;  // -1: no answer (the connection failed)
  std::string body;
  std::string content_type;
  httplib::Headers headers;
  nlohmann::json j;  // discarded if the body is not JSON
};

inline HttpAnswer answer_of(const httplib::Result& r) {
  HttpAnswer a;
  if (!r) return a;
  a.status = r->status;
  a.body = r->body;
  a.content_type = r->get_header_value("Content-Type");
  a.headers = r->headers;
  a.j = nlohmann::json::parse(r->body, nullptr, false);
  return a;
}

}  // namespace gaugeloop::testing

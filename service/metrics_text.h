// The Prometheus text /metrics answers with: the series read from the run database, and the
// escaping every label value needs. docs/http_api.md, "/metrics".
#pragma once

#include <string>

#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

// A label value escaped as the Prometheus text format asks (backslash, quote, newline).
std::string prometheus_label_value(const std::string& value);

// The series read from the run database, appended to `out` only if every query succeeded.
Status append_database_metrics(const RunStore& store, std::string& out);

}  // namespace gaugeloop

// Names of error codes, for logs and reports.
#include "core/result.h"

namespace gaugeloop {

std::string_view error_code_name(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidInput:
      return "invalid input";
    case ErrorCode::kNotFound:
      return "not found";
    case ErrorCode::kIo:
      return "i/o error";
    case ErrorCode::kGaugeUnreachable:
      return "gauge unreachable";
    case ErrorCode::kGaugeTimeout:
      return "gauge timeout";
    case ErrorCode::kGaugeProtocol:
      return "gauge protocol error";
    case ErrorCode::kIncompleteRun:
      return "incomplete run";
    case ErrorCode::kStorage:
      return "storage error";
    case ErrorCode::kRefused:
      return "refused";
    case ErrorCode::kInternal:
      return "internal error";
  }
  return "unknown error";
}

}  // namespace gaugeloop

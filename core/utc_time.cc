// UTC times, formatted and read back.
#include "core/utc_time.h"

#include <cctype>
#include <chrono>
#include <cstdio>

namespace gaugeloop {
namespace {

std::string formatted(std::time_t t, const char* format) {
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, format, &tm);
  return buf;
}

std::time_t now() { return std::chrono::system_clock::to_time_t(std::chrono::system_clock::now()); }

}  // namespace

std::string format_utc(std::time_t t) { return formatted(t, "%Y-%m-%dT%H:%M:%SZ"); }

std::string utc_now() { return format_utc(now()); }

std::string utc_file_stamp() { return formatted(now(), "%Y%m%dT%H%M%SZ"); }

bool is_utc_timestamp(std::string_view s) {
  constexpr std::string_view kShape = "dddd-dd-ddTdd:dd:ddZ";
  if (s.size() != kShape.size()) return false;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const bool digit = std::isdigit(static_cast<unsigned char>(s[i])) != 0;
    if (kShape[i] == 'd' ? !digit : s[i] != kShape[i]) return false;
  }
  auto field = [s](std::size_t at) { return (s[at] - '0') * 10 + (s[at + 1] - '0'); };
  const int month = field(5), day = field(8), hour = field(11), minute = field(14), second = field(17);
  return month >= 1 && month <= 12 && day >= 1 && day <= 31 && hour <= 23 && minute <= 59 &&
         second <= 60;  // 60: a leap second
}

bool is_calendar_date(std::string_view s) {
  if (s.size() != 10 || !is_utc_timestamp(std::string(s) + "T00:00:00Z")) return false;
  const std::optional<std::time_t> t = epoch_of_utc(std::string(s) + "T00:00:00Z");
  return t && format_utc(*t).substr(0, 10) == s;  // timegm carries 02-30 into March
}

bool is_past_calendar_date(std::string_view s) { return is_calendar_date(s) && s <= utc_now().substr(0, 10); }

std::optional<std::time_t> epoch_of_utc(const std::string& utc) {
  std::tm tm{};
  int consumed = 0;
  if (std::sscanf(utc.c_str(), "%4d-%2d-%2dT%2d:%2d:%2dZ%n", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour,
                  &tm.tm_min, &tm.tm_sec, &consumed) != 6 ||
      static_cast<std::size_t>(consumed) != utc.size()) {
    return std::nullopt;
  }
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  return timegm(&tm);
}

}  // namespace gaugeloop

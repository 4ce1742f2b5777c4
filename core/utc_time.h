// UTC times as gaugeloop writes them: "YYYY-MM-DDTHH:MM:SSZ", fixed width, so that text order
// is time order (the database, the JSON, the HTTP API and file names all use these).
#pragma once

#include <ctime>
#include <optional>
#include <string>
#include <string_view>

namespace gaugeloop {

// `t` as "2026-11-22T02:34:44Z".
std::string format_utc(std::time_t t);

// Now, as format_utc.
std::string utc_now();

// Now as "20261122T023444Z": a time for a file name, without colons.
std::string utc_file_stamp();

// Exactly "YYYY-MM-DDTHH:MM:SSZ" with plausible field ranges (a second of 60: a leap second).
bool is_utc_timestamp(std::string_view s);

// Exactly "YYYY-MM-DD", a day of the calendar (2026-02-30 is not).
bool is_calendar_date(std::string_view s);

// A calendar day (is_calendar_date) that is today or earlier, UTC: a calibration date.
bool is_past_calendar_date(std::string_view s);

// Seconds since the epoch of a "YYYY-MM-DDTHH:MM:SSZ"; empty if it is not one.
std::optional<std::time_t> epoch_of_utc(const std::string& utc);

}  // namespace gaugeloop

// Global identity: every run, push, event and plant message carries a random UUID, so records
// from many grinders meet in one central history without colliding.
#pragma once

#include <string>
#include <string_view>

namespace gaugeloop {

// A new random (version 4, RFC 9562) UUID in its canonical lower-case text form,
// "xxxxxxxx-xxxx-4xxx-Yxxx-xxxxxxxxxxxx" with Y one of 8, 9, a, b: 122 random bits from the
// operating system's generator (std::random_device), safe to call from any thread.
std::string new_uuid();

// Exactly the canonical text form: 36 characters, lower-case hex digits and hyphens at 8, 13,
// 18 and 23. Any version and variant.
bool is_uuid(std::string_view text);

}  // namespace gaugeloop

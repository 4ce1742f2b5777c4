// Formatting numbers and angle ranges for error messages.
#include "compensation/message_text.h"

#include <cmath>
#include <cstdio>
#include <utility>

namespace gaugeloop {

std::string describe_angle_ranges(const std::vector<double>& angle_deg, const std::vector<bool>& flagged,
                                  int max_ranges) {
  const size_t n = angle_deg.size();
  if (n == 0 || flagged.size() != n) return "";
  // Start scanning just after an unflagged sample so a run across the wrap stays whole.
  size_t start = n;
  for (size_t i = 0; i < n; ++i) {
    if (!flagged[i]) {
      start = (i + 1) % n;
      break;
    }
  }
  auto wrap = [](double a) {
    double w = std::fmod(a, 360.0);
    if (w < 0.0) w += 360.0;
    return w;
  };
  if (start == n) {
    return "all angles (" + format_fixed(wrap(angle_deg.front()), 1) + " deg round to " +
           format_fixed(wrap(angle_deg.back()), 1) + " deg)";
  }
  std::vector<std::pair<double, double>> ranges;
  size_t count = 0;
  size_t k = 0;
  while (k < n) {
    const size_t i = (start + k) % n;
    if (!flagged[i]) {
      ++k;
      continue;
    }
    const double from = angle_deg[i];
    double to = from;
    while (k < n && flagged[(start + k) % n]) {
      to = angle_deg[(start + k) % n];
      ++k;
    }
    ++count;
    if (static_cast<int>(ranges.size()) < max_ranges) ranges.emplace_back(from, to);
  }
  std::string text;
  for (size_t r = 0; r < ranges.size(); ++r) {
    if (r > 0) text += (r + 1 == ranges.size() && count == ranges.size()) ? " and " : ", ";
    const auto [from, to] = ranges[r];
    if (from == to) {
      text += format_fixed(wrap(from), 1) + " deg";
    } else {
      text += format_fixed(wrap(from), 1) + " to " + format_fixed(wrap(to), 1) + " deg";
    }
  }
  if (count > ranges.size()) {
    text += " and " + std::to_string(count - ranges.size()) + " more range(s)";
  }
  return text;
}

}  // namespace gaugeloop

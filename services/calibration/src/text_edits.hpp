// Text edits for writing calibrated files: the file as its author wrote it, with a few spans replaced.
// Private to services/calibration (calibrated_robot.cpp, urdf_trunk_mass.cpp).
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace cpgmatch::calibration {

// A text edit: replace [begin, end) by `text`. Edits are applied from the last to the first, so that the
// offsets of the others (taken on the original text) stay right.
struct Edit {
  std::size_t begin = 0, end = 0;
  std::string text;
};

inline std::string apply_edits(std::string text, std::vector<Edit> edits) {
  std::sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) { return a.begin > b.begin; });
  for (const Edit& e : edits) text.replace(e.begin, e.end - e.begin, e.text);
  return text;
}

// A double in its shortest form that reads back as the same double, with a decimal point (YAML then reads a
// float, as the hand-written entries are).
inline std::string exact_decimal(double v) {
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

}  // namespace cpgmatch::calibration

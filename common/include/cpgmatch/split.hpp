// A text cut at every separator: "a,b,,c" -> {"a", "b", "", "c"}; "" -> {""}. Empty parts are kept so that
// callers can refuse them with a message of their own (a CSV header's cell, a dotted path's step, a list item).
#pragma once

#include <string_view>
#include <vector>

namespace cpgmatch {

inline std::vector<std::string_view> split_on(std::string_view text, char separator) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t at = text.find(separator, start);
    parts.push_back(text.substr(start, at == std::string_view::npos ? std::string_view::npos : at - start));
    if (at == std::string_view::npos) return parts;
    start = at + 1;
  }
}

}  // namespace cpgmatch

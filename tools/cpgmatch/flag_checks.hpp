// Range checks for numeric flags. CLI11's Range lets NaN through (every comparison with NaN is false), so
// a rollout could run with `--treadmill nan` and "fall"; these refuse non-finite values as well.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <system_error>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

namespace cpgmatch::cli {

// A finite number in [low, high] (with its unit in the message).
inline CLI::Validator finite_in(double low, double high, const std::string& unit) {
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v = 0.0;
        try {
          std::size_t used = 0;
          v = std::stod(text, &used);
          if (used != text.size()) return fmt::format("'{}' is not a number", text);
        } catch (const std::exception&) {
          return fmt::format("'{}' is not a number", text);
        }
        if (!std::isfinite(v) || v < low || v > high) return fmt::format("{} must be in [{}, {}] {}", text, low, high, unit);
        return "";
      },
      fmt::format("in [{}, {}] {}", low, high, unit));
}

// A study id: a whole number >= 1. The message names the value given ("-1" became study 0 on the way and the
// service answered "no study 0").
inline CLI::Validator study_id() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        const bool digits = !text.empty() && text.size() <= 9 && text.find_first_not_of("0123456789") == std::string::npos;
        if (!digits || std::stoi(text) < 1) {
          return fmt::format("'{}' is not a study id (a whole number >= 1)", text.substr(0, 40));
        }
        return "";
      },
      "a study id (>= 1)");
}

// A whole number in [0, 2^64 - 1], for seeds: "-1" must not wrap around to 2^64 - 1, nor a longer number be
// cut down to 2^64 - 1 by the conversion (both were accepted and ran as seed 2^64 - 1).
inline CLI::Validator whole_non_negative() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) {
          return fmt::format("'{}' must be a whole number >= 0", text);
        }
        std::uint64_t value = 0;
        if (std::from_chars(text.data(), text.data() + text.size(), value).ec == std::errc::result_out_of_range) {
          return fmt::format("'{}' is larger than {}", text, std::numeric_limits<std::uint64_t>::max());
        }
        return "";
      },
      "whole number >= 0");
}

}  // namespace cpgmatch::cli

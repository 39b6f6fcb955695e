// How long the event loop keeps samples waiting: for each sample, the time from its arrival (queued by a
// DDS listener) to the end of its handling, and the duration of each tick. The service logs a summary on
// SIGUSR1 and at exit; the throughput benchmark reads it (the p99 target is 20 ms).
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace cpgmatch::service {

class LatencyRecorder {
 public:
  void add(double seconds) {
    if (samples_.size() < kMaxSamples) samples_.push_back(seconds);
    max_ = std::max(max_, seconds);
    ++count_;
  }
  // "n 1234, p50 0.31 ms, p99 4.2 ms, max 9.8 ms" (percentiles over the first kMaxSamples since reset).
  std::string summary() const {
    if (samples_.empty()) return "n 0";
    std::vector<double> v = samples_;
    std::sort(v.begin(), v.end());
    auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))]; };
    return fmt::format("n {}, p50 {:.2f} ms, p99 {:.2f} ms, max {:.2f} ms", count_, 1e3 * at(0.5), 1e3 * at(0.99),
                       1e3 * max_);
  }
  void reset() { *this = LatencyRecorder{}; }

 private:
  static constexpr std::size_t kMaxSamples = 1 << 20;  // 8 MB at most; a summary per benchmark run
  std::vector<double> samples_;
  double max_ = 0.0;
  std::size_t count_ = 0;
};

}  // namespace cpgmatch::service

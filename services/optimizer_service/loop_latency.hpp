// How long the event loop keeps samples waiting: for each sample, the time from its arrival (queued by a
// DDS listener) to the end of its handling, and the duration of each tick. The service logs a summary on
// SIGUSR1 and at exit; the throughput benchmark reads it (the p99 target is 20 ms).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace cpgmatch::service {

// Percentiles over a uniform sample of everything recorded since the start (a reservoir of kMaxSamples:
// exact for a benchmark run, 512 kB per recorder for a service that runs for months); count and max are
// exact.
class LatencyRecorder {
 public:
  void add(double seconds) {
    max_ = std::max(max_, seconds);
    ++count_;
    if (samples_.size() < kMaxSamples) {
      samples_.push_back(seconds);
      return;
    }
    // Reservoir sampling (Vitter's algorithm R): the k-th value replaces a random slot with probability
    // kMaxSamples / k. A fixed-seed xorshift: the order of events is what varies, not the sampler.
    const std::uint64_t slot = next_random() % count_;
    if (slot < kMaxSamples) samples_[slot] = seconds;
  }
  // "n 1234, p50 0.31 ms, p99 4.2 ms, max 9.8 ms".
  std::string summary() const {
    if (samples_.empty()) return "n 0";
    std::vector<double> v = samples_;
    auto at = [&](double q) {
      const auto k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())));
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
      return v[k];
    };
    const double p50 = at(0.5), p99 = at(0.99);
    return fmt::format("n {}, p50 {:.2f} ms, p99 {:.2f} ms, max {:.2f} ms", count_, 1e3 * p50, 1e3 * p99, 1e3 * max_);
  }

  static constexpr std::size_t kMaxSamples = 1 << 16;

 private:
  std::uint64_t next_random() {
    state_ ^= state_ << 13;
    state_ ^= state_ >> 7;
    state_ ^= state_ << 17;
    return state_;
  }

  std::vector<double> samples_;
  double max_ = 0.0;
  std::size_t count_ = 0;
  std::uint64_t state_ = 0x9E3779B97F4A7C15ULL;
};

}  // namespace cpgmatch::service

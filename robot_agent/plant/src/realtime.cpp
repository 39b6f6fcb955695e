#include "cpgmatch/robot/realtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

namespace cpgmatch::robot {
namespace {

constexpr std::size_t kBins = 100'001;  // 0..100000 us

struct timespec from_ns(std::int64_t ns) {
  struct timespec ts;
  ts.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(ns % 1'000'000'000);
  return ts;
}

}  // namespace

std::int64_t to_ns(const struct timespec& ts) { return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec; }

std::int64_t monotonic_ns() {
  struct timespec now;
  clock_gettime(CLOCK_MONOTONIC, &now);
  return to_ns(now);
}

RealtimeSetup enter_realtime(int priority) {
  RealtimeSetup setup;
  std::string refused;
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
    setup.memory_locked = true;
  } else {
    refused += fmt::format("mlockall refused ({}); ", std::strerror(errno));
  }
  struct sched_param param {};
  param.sched_priority = std::clamp(priority, sched_get_priority_min(SCHED_FIFO), sched_get_priority_max(SCHED_FIFO));
  const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  if (rc == 0) {
    setup.fifo_scheduling = true;
  } else {
    refused += fmt::format("SCHED_FIFO priority {} refused ({}); ", param.sched_priority, std::strerror(rc));
  }
  if (!refused.empty()) {
    setup.warning = refused +
                    "the control loop runs best-effort with more jitter. Grant CAP_SYS_NICE and CAP_IPC_LOCK "
                    "(or rtprio/memlock limits in /etc/security/limits.conf) for real-time scheduling.";
  }
  return setup;
}

JitterStats::JitterStats() : bins_(kBins, 0) {}

void JitterStats::record(std::int64_t lateness_ns) {
  lateness_ns = std::max<std::int64_t>(lateness_ns, 0);
  const auto bin = std::min<std::size_t>(static_cast<std::size_t>(lateness_ns / 1000), kBins - 1);
  ++bins_[bin];
  ++samples_;
  max_ns_ = std::max(max_ns_, lateness_ns);
}

void JitterStats::reset() {
  std::fill(bins_.begin(), bins_.end(), 0u);
  samples_ = 0;
  overruns_ = 0;
  max_ns_ = 0;
}

double JitterStats::percentile_us(double p) const {
  if (samples_ == 0) return 0.0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(std::clamp(p, 0.0, 1.0) * static_cast<double>(samples_)));
  std::uint64_t seen = 0;
  for (std::size_t i = 0; i < bins_.size(); ++i) {
    seen += bins_[i];
    if (seen >= std::max<std::uint64_t>(rank, 1)) return static_cast<double>(i);  // the bin's lower edge, us
  }
  return max_us();
}

void PeriodicTimer::start() { deadline_ = from_ns(monotonic_ns() + period_ns_); }

std::int64_t PeriodicTimer::wait(bool& passed) {
  const std::int64_t deadline = to_ns(deadline_);
  passed = monotonic_ns() > deadline;
  if (!passed) {
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline_, nullptr) == EINTR) {
    }
  }
  const std::int64_t lateness = monotonic_ns() - deadline;
  deadline_ = from_ns(deadline + period_ns_);
  return lateness;
}

}  // namespace cpgmatch::robot

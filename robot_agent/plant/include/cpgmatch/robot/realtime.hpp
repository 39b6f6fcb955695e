// Real-time loop tools: the process/thread setup (SCHED_FIFO, locked memory), a periodic timer that
// sleeps to absolute deadlines, and jitter statistics that record without allocating.
#pragma once

#include <cstdint>
#include <ctime>
#include <string>
#include <vector>

namespace cpgmatch::robot {

struct RealtimeSetup {
  bool memory_locked = false;
  bool fifo_scheduling = false;
  std::string warning;  // empty when both were granted; otherwise what was refused and how to allow it
};

// Locks current and future memory (mlockall) and moves the calling thread to SCHED_FIFO at `priority`.
// Neither is fatal when refused (no CAP_SYS_NICE / CAP_IPC_LOCK, rtprio limits): the loop then runs
// best-effort and the warning says so, as ros2_control does.
RealtimeSetup enter_realtime(int priority);

// Wake-up lateness after each absolute deadline (cyclictest's measure) in 1-microsecond bins up to
// 100 ms (later wake-ups land in the last bin; max keeps the exact value). The bins are allocated once
// at construction: record() never allocates.
class JitterStats {
 public:
  JitterStats();
  void record(std::int64_t lateness_ns);
  void add_overrun() { ++overruns_; }
  void reset();
  std::uint64_t samples() const { return samples_; }
  std::uint64_t overruns() const { return overruns_; }
  double percentile_us(double p) const;  // p in [0, 1]
  double max_us() const { return max_ns_ / 1000.0; }

 private:
  std::vector<std::uint32_t> bins_;
  std::uint64_t samples_ = 0;
  std::uint64_t overruns_ = 0;
  std::int64_t max_ns_ = 0;
};

// Absolute-deadline periodic timer on CLOCK_MONOTONIC (clock_nanosleep with TIMER_ABSTIME), so sleep
// errors never accumulate into drift.
class PeriodicTimer {
 public:
  explicit PeriodicTimer(std::int64_t period_ns) : period_ns_(period_ns) {}
  void start();                           // the first deadline is one period from now
  const struct timespec& deadline() const { return deadline_; }
  // Sleeps until the current deadline and moves it one period on. Returns the wake-up lateness (ns).
  // When the deadline had already passed on entry, `passed` is set and it returns at once: the loop
  // catches up instead of skipping periods (every period is one control step of the rollout).
  std::int64_t wait(bool& passed);
  std::int64_t period_ns() const { return period_ns_; }

 private:
  std::int64_t period_ns_;
  struct timespec deadline_ {};
};

std::int64_t monotonic_ns();
std::int64_t to_ns(const struct timespec& ts);

}  // namespace cpgmatch::robot

// The bus backends, private to the CAN library: open_can_bus() picks one from the URI.
#pragma once

#include <atomic>
#include <memory>
#include <vector>

#include "cpgmatch/can/bus_uri.hpp"
#include "cpgmatch/can/can_bus.hpp"

namespace cpgmatch::can::detail {

std::unique_ptr<CanBus> open_socketcan(const BusUri& uri);
std::unique_ptr<CanBus> open_udp(const BusUri& uri, BusRole role);
std::unique_ptr<CanBus> open_virtual(const BusUri& uri);

// Receive filtering done in software (udp and virtual), with SocketCAN's semantics.
class SoftwareFilter {
 public:
  void set(std::span<const CanFilter> filters) { filters_.assign(filters.begin(), filters.end()); }
  void set_error_frames(bool enabled) { error_frames_ = enabled; }
  bool accepts(const CanFrame& frame) const {
    if (frame.error) return error_frames_;
    if (filters_.empty()) return true;
    for (const CanFilter& f : filters_) {
      if (f.matches(frame)) return true;
    }
    return false;
  }

 private:
  std::vector<CanFilter> filters_;
  bool error_frames_ = false;
};

// Counters written by the bus's user thread and read by any (a monitor, the agent's report).
struct AtomicCounters {
  std::atomic<std::uint64_t> sent{0}, received{0}, filtered_out{0}, malformed{0}, dropped{0};
  BusCounters snapshot() const {
    return {sent.load(std::memory_order_relaxed), received.load(std::memory_order_relaxed),
            filtered_out.load(std::memory_order_relaxed), malformed.load(std::memory_order_relaxed),
            dropped.load(std::memory_order_relaxed)};
  }
};

// Converts a relative timeout into poll()'s timespec.
struct timespec to_timespec(std::chrono::nanoseconds timeout);

}  // namespace cpgmatch::can::detail

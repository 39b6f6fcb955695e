#include <ctime>

#include "backends.hpp"

namespace cpgmatch::can {

std::unique_ptr<CanBus> open_can_bus(const std::string& text, BusRole role) {
  const BusUri uri = parse_bus_uri(text);
  switch (uri.scheme) {
    case BusUri::Scheme::kSocketCan: return detail::open_socketcan(uri);
    case BusUri::Scheme::kUdp: return detail::open_udp(uri, role);
    case BusUri::Scheme::kVirtual: return detail::open_virtual(uri);
  }
  return nullptr;
}

namespace detail {

struct timespec to_timespec(std::chrono::nanoseconds timeout) {
  if (timeout.count() < 0) timeout = std::chrono::nanoseconds(0);
  struct timespec ts;
  ts.tv_sec = static_cast<time_t>(timeout.count() / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(timeout.count() % 1'000'000'000);
  return ts;
}

}  // namespace detail
}  // namespace cpgmatch::can

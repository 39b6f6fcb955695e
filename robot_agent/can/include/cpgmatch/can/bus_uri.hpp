// Parsing of CAN bus URIs: socketcan:IFACE, udp:HOST:PORT, virtual:NAME.
#pragma once

#include <cstdint>
#include <string>

namespace cpgmatch::can {

struct BusUri {
  enum class Scheme { kSocketCan, kUdp, kVirtual };
  Scheme scheme = Scheme::kVirtual;
  std::string text;        // the URI as given
  std::string interface;   // socketcan: the network interface (can0, vcan0)
  std::string host;        // udp: IPv4 address or host name
  std::uint16_t port = 0;  // udp: 1..65535
  std::string name;        // virtual: the bus name
};

// Throws InputError naming the part that is wrong: the scheme, an empty or too long interface name,
// a missing host or port, a port that is not a number in 1..65535, an empty virtual bus name.
BusUri parse_bus_uri(const std::string& text);

}  // namespace cpgmatch::can

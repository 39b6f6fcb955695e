#include "cpgmatch/can/bus_uri.hpp"

#include <net/if.h>

#include <charconv>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::can {
namespace {

[[noreturn]] void bad(const std::string& uri, const std::string& what) {
  throw InputError(fmt::format("CAN bus URI '{}': {}", uri, what));
}

}  // namespace

BusUri parse_bus_uri(const std::string& text) {
  BusUri uri;
  uri.text = text;
  const auto colon = text.find(':');
  if (colon == std::string::npos) {
    bad(text, "no scheme; expected socketcan:IFACE, udp:HOST:PORT or virtual:NAME");
  }
  const std::string scheme = text.substr(0, colon);
  const std::string rest = text.substr(colon + 1);
  if (scheme == "socketcan") {
    uri.scheme = BusUri::Scheme::kSocketCan;
    if (rest.empty()) bad(text, "interface name is empty (e.g. socketcan:can0)");
    if (rest.size() >= IFNAMSIZ) bad(text, fmt::format("interface name '{}' is longer than {} characters", rest, IFNAMSIZ - 1));
    if (rest.find_first_of(":/ \t") != std::string::npos) bad(text, fmt::format("interface name '{}' has a ':', '/' or blank", rest));
    uri.interface = rest;
  } else if (scheme == "udp") {
    uri.scheme = BusUri::Scheme::kUdp;
    const auto port_colon = rest.rfind(':');
    if (port_colon == std::string::npos) bad(text, "missing ':PORT' (expected udp:HOST:PORT)");
    uri.host = rest.substr(0, port_colon);
    const std::string port = rest.substr(port_colon + 1);
    if (uri.host.empty()) bad(text, "host is empty (expected udp:HOST:PORT)");
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
    if (port.empty() || ec != std::errc() || end != port.data() + port.size() || value < 1 || value > 65535) {
      bad(text, fmt::format("port '{}' must be a number in 1..65535", port));
    }
    uri.port = static_cast<std::uint16_t>(value);
  } else if (scheme == "virtual") {
    uri.scheme = BusUri::Scheme::kVirtual;
    if (rest.empty()) bad(text, "bus name is empty (e.g. virtual:test)");
    uri.name = rest;
  } else {
    bad(text, fmt::format("unknown scheme '{}' (expected socketcan, udp or virtual)", scheme));
  }
  return uri;
}

}  // namespace cpgmatch::can

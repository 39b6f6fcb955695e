// SocketCAN backend: a PF_CAN raw socket bound to one interface. Filters are the kernel's
// (CAN_RAW_FILTER), error frames its CAN_RAW_ERR_FILTER, timeouts ppoll(). CAN-FD frames go as struct
// canfd_frame once CAN_RAW_FD_FRAMES is on; that works only on an interface configured for FD (MTU 72:
// `ip link set can0 type can bitrate 1000000 dbitrate 5000000 fd on`), which the constructor reads.
#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include <fmt/format.h>

#include "backends.hpp"

namespace cpgmatch::can::detail {
namespace {

std::string errno_text(int error) { return std::strerror(error); }

class SocketCanBus final : public CanBus {
 public:
  explicit SocketCanBus(const BusUri& uri) : uri_(uri.text) {
    fd_ = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (fd_ < 0) {
      const int error = errno;
      if (error == EAFNOSUPPORT || error == EPROTONOSUPPORT) {
        throw CanError(fmt::format("{}: this kernel has no SocketCAN (AF_CAN): {} (load the can and can_raw "
                                   "modules, or use udp:HOST:PORT through a gateway)",
                                   uri_, errno_text(error)));
      }
      throw CanError(fmt::format("{}: cannot open a CAN raw socket: {}", uri_, errno_text(error)));
    }
    struct ifreq ifr {};
    std::strncpy(ifr.ifr_name, uri.interface.c_str(), IFNAMSIZ - 1);
    if (::ioctl(fd_, SIOCGIFINDEX, &ifr) < 0) {
      const int error = errno;
      ::close(fd_);
      throw CanError(fmt::format("{}: no network interface '{}': {}", uri_, uri.interface, errno_text(error)));
    }
    struct sockaddr_can address {};
    address.can_family = AF_CAN;
    address.can_ifindex = ifr.ifr_ifindex;
    if (::bind(fd_, reinterpret_cast<struct sockaddr*>(&address), sizeof(address)) < 0) {
      const int error = errno;
      ::close(fd_);
      throw CanError(fmt::format("{}: cannot bind to '{}': {}", uri_, uri.interface, errno_text(error)));
    }
    set_error_frames(false);
    // FD frames on the socket are harmless for classic use: the kernel still reads classic frames as
    // CAN_MTU-sized reads. Whether the interface itself is FD decides whether FD frames can be sent.
    const int on = 1;
    fd_frames_ = ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof(on)) == 0;
    if (::ioctl(fd_, SIOCGIFMTU, &ifr) == 0) interface_mtu_ = ifr.ifr_mtu;
  }
  ~SocketCanBus() override { ::close(fd_); }

  void send(const CanFrame& frame) override {
    if (auto problem = frame_problem(frame)) throw CanError(fmt::format("{}: cannot send {}: {}", uri_, to_string(frame), *problem));
    const canid_t id = frame.id | (frame.extended ? CAN_EFF_FLAG : 0u) | (frame.remote ? CAN_RTR_FLAG : 0u);
    ssize_t n = 0;
    std::size_t size = 0;
    if (frame.fd) {
      if (!fd_frames_ || interface_mtu_ != static_cast<int>(CANFD_MTU)) {
        throw CanError(fmt::format("{}: cannot send the CAN-FD frame {}: the interface is not in CAN-FD mode (MTU {}, "
                                   "needs {}: ip link set IFACE type can bitrate 1000000 dbitrate 5000000 fd on)",
                                   uri_, to_string(frame), interface_mtu_, CANFD_MTU));
      }
      struct canfd_frame raw {};
      raw.can_id = id;
      raw.len = frame.length;
      raw.flags = frame.bit_rate_switch ? CANFD_BRS : 0;
      std::memcpy(raw.data, frame.data.data(), frame.length);
      size = sizeof(raw);
      n = ::write(fd_, &raw, size);
    } else {
      struct can_frame raw {};
      raw.can_id = id;
      raw.can_dlc = frame.length;
      std::memcpy(raw.data, frame.data.data(), frame.length);
      size = sizeof(raw);
      n = ::write(fd_, &raw, size);
    }
    if (n != static_cast<ssize_t>(size)) {
      throw CanError(fmt::format("{}: send failed: {}", uri_, n < 0 ? errno_text(errno) : "short write"));
    }
    ++counters_.sent;
  }

  bool receive(CanFrame& out, std::chrono::nanoseconds timeout) override {
    struct pollfd pfd {fd_, POLLIN, 0};
    const struct timespec ts = to_timespec(timeout);
    const int ready = ::ppoll(&pfd, 1, &ts, nullptr);
    if (ready < 0) {
      if (errno == EINTR) return false;
      throw CanError(fmt::format("{}: poll failed: {}", uri_, errno_text(errno)));
    }
    if (ready == 0) return false;
    // With CAN_RAW_FD_FRAMES a read returns CAN_MTU bytes for a classic frame and CANFD_MTU for an FD one;
    // the two structs share their header layout.
    struct canfd_frame raw {};
    const ssize_t n = ::read(fd_, &raw, sizeof(raw));
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) return false;
      throw CanError(fmt::format("{}: receive failed: {}", uri_, errno_text(errno)));
    }
    const bool fd = n == static_cast<ssize_t>(CANFD_MTU);
    if ((!fd && n != static_cast<ssize_t>(CAN_MTU)) || raw.len > (fd ? CANFD_MAX_DLEN : CAN_MAX_DLEN)) {
      ++counters_.malformed;
      return false;
    }
    out = CanFrame{};
    out.error = (raw.can_id & CAN_ERR_FLAG) != 0;
    out.extended = (raw.can_id & CAN_EFF_FLAG) != 0;
    out.remote = (raw.can_id & CAN_RTR_FLAG) != 0;
    out.id = raw.can_id & (out.error ? CAN_ERR_MASK : out.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
    out.fd = fd;
    out.bit_rate_switch = fd && (raw.flags & CANFD_BRS) != 0;
    out.length = raw.len;
    std::memcpy(out.data.data(), raw.data, raw.len);
    ++counters_.received;
    return true;
  }

  void set_filters(std::span<const CanFilter> filters) override {
    std::vector<struct can_filter> raw;
    for (const CanFilter& f : filters) {
      // The EFF flag in both id and mask makes the id width part of the match, as CanFilter::matches.
      raw.push_back({f.id | (f.extended ? CAN_EFF_FLAG : 0u), f.mask | CAN_EFF_FLAG});
    }
    if (raw.empty()) raw.push_back({0, 0});  // accept every data frame
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, raw.data(), static_cast<socklen_t>(raw.size() * sizeof(raw[0]))) < 0) {
      throw CanError(fmt::format("{}: cannot set receive filters: {}", uri_, errno_text(errno)));
    }
  }

  void set_error_frames(bool enabled) override {
    const can_err_mask_t mask = enabled ? CAN_ERR_MASK : 0;
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &mask, sizeof(mask)) < 0) {
      throw CanError(fmt::format("{}: cannot set the error frame filter: {}", uri_, errno_text(errno)));
    }
  }

  const std::string& uri() const override { return uri_; }
  BusCounters counters() const override { return counters_.snapshot(); }

 private:
  std::string uri_;
  int fd_ = -1;
  bool fd_frames_ = false;  // CAN_RAW_FD_FRAMES accepted by the kernel
  int interface_mtu_ = 0;   // CAN_MTU (16) classic, CANFD_MTU (72) an FD interface
  AtomicCounters counters_;
};

}  // namespace

std::unique_ptr<CanBus> open_socketcan(const BusUri& uri) { return std::make_unique<SocketCanBus>(uri); }

}  // namespace cpgmatch::can::detail

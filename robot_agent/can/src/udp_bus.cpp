// udp backend: CAN frames in UDP datagrams (format in udp_frame.hpp), IPv4. The controller side sends
// to HOST:PORT and accepts datagrams from there only (a connected socket); the device side binds
// HOST:PORT and sends to whoever sent to it last, so one emulator or gateway serves the agent that talks
// to it. A datagram that is not a whole number of valid frames is counted as malformed and dropped.
#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "backends.hpp"
#include "cpgmatch/can/udp_frame.hpp"

namespace cpgmatch::can::detail {
namespace {

struct sockaddr_in resolve(const BusUri& uri) {
  struct addrinfo hints {};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  struct addrinfo* found = nullptr;
  const int rc = ::getaddrinfo(uri.host.c_str(), nullptr, &hints, &found);
  if (rc != 0 || found == nullptr) {
    throw CanError(fmt::format("{}: cannot resolve host '{}': {}", uri.text, uri.host, ::gai_strerror(rc)));
  }
  struct sockaddr_in address;
  std::memcpy(&address, found->ai_addr, sizeof(address));
  ::freeaddrinfo(found);
  address.sin_port = htons(uri.port);
  return address;
}

class UdpBus final : public CanBus {
 public:
  UdpBus(const BusUri& uri, BusRole role) : uri_(uri.text), role_(role) {
    const struct sockaddr_in address = resolve(uri);
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw CanError(fmt::format("{}: cannot open a UDP socket: {}", uri_, std::strerror(errno)));
    const auto* sa = reinterpret_cast<const struct sockaddr*>(&address);
    if (role == BusRole::kDevice) {
      const int yes = 1;
      ::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
      if (::bind(fd_, sa, sizeof(address)) < 0) {
        const int error = errno;
        ::close(fd_);
        throw CanError(fmt::format("{}: cannot bind {}:{}: {}", uri_, uri.host, uri.port, std::strerror(error)));
      }
    } else if (::connect(fd_, sa, sizeof(address)) < 0) {
      const int error = errno;
      ::close(fd_);
      throw CanError(fmt::format("{}: cannot address {}:{}: {}", uri_, uri.host, uri.port, std::strerror(error)));
    }
  }
  ~UdpBus() override { ::close(fd_); }

  void send(const CanFrame& frame) override { send(std::span<const CanFrame>(&frame, 1)); }

  // Thread-safe against receive() and other send() calls on the controller side (the agent's watchdog
  // sends from its own thread): the datagram is built on the stack and send(2) is atomic per datagram.
  void send(std::span<const CanFrame> frames) override {
    std::uint8_t tx[kMaxDatagramSize];
    while (!frames.empty()) {
      const std::size_t count = std::min(frames.size(), kMaxFramesPerDatagram);
      std::size_t bytes = 0;
      for (std::size_t i = 0; i < count; ++i) {
        if (auto problem = frame_problem(frames[i])) {
          throw CanError(fmt::format("{}: cannot send {}: {}", uri_, to_string(frames[i]), *problem));
        }
        bytes += encode_udp_record(frames[i], std::span<std::uint8_t>(tx + bytes, sizeof(tx) - bytes));
      }
      transmit(tx, bytes, count);
      frames = frames.subspan(count);
    }
  }

  bool receive(CanFrame& out, std::chrono::nanoseconds timeout) override {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (true) {
      while (next_ < pending_) {
        const CanFrame& frame = rx_frames_[next_++];
        if (filter_.accepts(frame)) {
          out = frame;
          counters_.received.fetch_add(1, std::memory_order_relaxed);
          return true;
        }
        counters_.filtered_out.fetch_add(1, std::memory_order_relaxed);
      }
      if (!read_datagram(deadline - std::chrono::steady_clock::now())) return false;
    }
  }

  void set_filters(std::span<const CanFilter> filters) override { filter_.set(filters); }
  void set_error_frames(bool enabled) override { filter_.set_error_frames(enabled); }
  const std::string& uri() const override { return uri_; }
  BusCounters counters() const override { return counters_.snapshot(); }

 private:
  void transmit(const std::uint8_t* tx, std::size_t bytes, std::size_t frames) {
    ssize_t n;
    if (role_ == BusRole::kDevice) {
      if (!have_peer_) {  // nobody has talked to us yet: like a CAN bus with no other node, the frame is lost
        counters_.dropped.fetch_add(frames, std::memory_order_relaxed);
        return;
      }
      n = ::sendto(fd_, tx, bytes, 0, reinterpret_cast<const struct sockaddr*>(&peer_), sizeof(peer_));
    } else {
      n = ::send(fd_, tx, bytes, 0);
    }
    if (n < 0) {
      // The peer is not (yet, or any more) listening, or the socket buffer is full: the frames are lost
      // as on a bus with nobody acknowledging. Missing replies are the watchdog's business.
      if (errno == ECONNREFUSED || errno == EAGAIN || errno == ENOBUFS || errno == EHOSTUNREACH || errno == ENETUNREACH) {
        counters_.dropped.fetch_add(frames, std::memory_order_relaxed);
        return;
      }
      throw CanError(fmt::format("{}: send failed: {}", uri_, std::strerror(errno)));
    }
    counters_.sent.fetch_add(frames, std::memory_order_relaxed);
  }

  // Reads one datagram into rx_frames_; false when none arrived in time.
  bool read_datagram(std::chrono::nanoseconds timeout) {
    struct pollfd pfd {fd_, POLLIN, 0};
    const struct timespec ts = to_timespec(timeout);
    const int ready = ::ppoll(&pfd, 1, &ts, nullptr);
    if (ready < 0) {
      if (errno == EINTR) return false;
      throw CanError(fmt::format("{}: poll failed: {}", uri_, std::strerror(errno)));
    }
    if (ready == 0) return false;
    struct sockaddr_in from {};
    socklen_t from_size = sizeof(from);
    const ssize_t n = ::recvfrom(fd_, rx_, sizeof(rx_), MSG_DONTWAIT | MSG_TRUNC,
                                 reinterpret_cast<struct sockaddr*>(&from), &from_size);
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR || errno == ECONNREFUSED) return true;  // nothing usable; try again
      throw CanError(fmt::format("{}: receive failed: {}", uri_, std::strerror(errno)));
    }
    if (n == 0 || static_cast<std::size_t>(n) > sizeof(rx_)) {
      counters_.malformed.fetch_add(1, std::memory_order_relaxed);
      return true;
    }
    // Classic (16-byte) and FD (72-byte) records, each sized by its own flags byte.
    std::size_t count = 0;
    for (std::size_t at = 0; at < static_cast<std::size_t>(n);) {
      std::size_t consumed = 0;
      auto frame = count < kMaxFramesPerDatagram
                       ? decode_udp_record(std::span<const std::uint8_t>(rx_ + at, static_cast<std::size_t>(n) - at), consumed)
                       : std::nullopt;
      if (!frame) {  // one bad record makes the whole datagram suspect
        counters_.malformed.fetch_add(1, std::memory_order_relaxed);
        return true;
      }
      rx_frames_[count++] = *frame;
      at += consumed;
    }
    if (role_ == BusRole::kDevice) {
      peer_ = from;
      have_peer_ = true;
    }
    pending_ = count;
    next_ = 0;
    return true;
  }

  std::string uri_;
  BusRole role_;
  int fd_ = -1;
  struct sockaddr_in peer_ {};
  bool have_peer_ = false;
  SoftwareFilter filter_;
  AtomicCounters counters_;
  std::uint8_t rx_[kMaxDatagramSize];
  CanFrame rx_frames_[kMaxFramesPerDatagram];
  std::size_t pending_ = 0;
  std::size_t next_ = 0;
};

}  // namespace

std::unique_ptr<CanBus> open_udp(const BusUri& uri, BusRole role) { return std::make_unique<UdpBus>(uri, role); }

}  // namespace cpgmatch::can::detail

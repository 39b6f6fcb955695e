// The CAN bus seen by the robot agent and the emulator: send and receive classic frames with timeouts,
// receive filters and error frames. The backend is chosen by a URI (see bus_uri.hpp):
//   socketcan:can0      a Linux CAN interface (PF_CAN raw socket), the robot's bus
//   udp:HOST:PORT       CAN frames in UDP datagrams (docs/robot_agent.md), for a gateway and the tests
//   virtual:NAME        an in-process bus shared by every endpoint opened with the same NAME (unit tests)
//
// Real-time use: send() and receive() neither allocate nor take locks on the socketcan and udp
// backends (the virtual bus takes a mutex; it is for tests). Failures are CanError exceptions, which
// only happen when the bus itself is broken.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>

#include "cpgmatch/can/can_frame.hpp"

namespace cpgmatch::can {

class CanError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Which side of a point-to-point link this endpoint is. Only the udp backend cares: the device side
// (the emulator, a CAN-to-UDP gateway) binds HOST:PORT and answers whoever last sent to it; the
// controller side (the agent) sends to HOST:PORT and accepts datagrams only from there.
enum class BusRole { kController, kDevice };

struct BusCounters {
  std::uint64_t sent = 0;
  std::uint64_t received = 0;         // frames handed to the caller
  std::uint64_t filtered_out = 0;     // frames dropped by the receive filters
  std::uint64_t malformed = 0;        // datagrams or frames that were not valid CAN frames
  std::uint64_t dropped = 0;          // frames lost: receive queue overflow, no peer to send to
};

class CanBus {
 public:
  virtual ~CanBus() = default;

  // Queues one frame for transmission; throws CanError for an invalid frame or a broken bus.
  virtual void send(const CanFrame& frame) = 0;
  // Several frames at once (the udp backend packs them into one datagram).
  virtual void send(std::span<const CanFrame> frames) {
    for (const CanFrame& f : frames) send(f);
  }

  // Waits at most `timeout` for the next frame that passes the filters (or an error frame, when
  // enabled). Returns false on timeout. A zero timeout only takes what has already arrived.
  virtual bool receive(CanFrame& out, std::chrono::nanoseconds timeout) = 0;

  // Frames matching any filter are received; an empty list receives every data frame.
  virtual void set_filters(std::span<const CanFilter> filters) = 0;
  // Error frames (bus-off, error passive, lost arbitration...) are received only when enabled.
  virtual void set_error_frames(bool enabled) = 0;

  virtual const std::string& uri() const = 0;
  virtual BusCounters counters() const = 0;
};

// Opens the bus a URI names. Throws InputError for a malformed URI (naming the wrong part) and CanError
// when the bus cannot be opened (e.g. "socketcan:can0: this kernel has no SocketCAN (AF_CAN): ...").
std::unique_ptr<CanBus> open_can_bus(const std::string& uri, BusRole role = BusRole::kController);

}  // namespace cpgmatch::can

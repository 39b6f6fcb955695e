// A CAN frame, classic (up to 8 data bytes) or CAN-FD (up to 64), and a receive filter, independent of
// any backend.
//
// The fields mirror Linux's struct can_frame / struct canfd_frame (linux/can.h) without the flag bits
// packed into the id, so code above the bus never depends on kernel headers; the SocketCAN backend and
// the UDP wire format map them back to CAN_EFF_FLAG / CAN_RTR_FLAG / CAN_ERR_FLAG and CANFD_BRS.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

namespace cpgmatch::can {

inline constexpr std::uint32_t kMaxStandardId = 0x7FF;        // 11 bits
inline constexpr std::uint32_t kMaxExtendedId = 0x1FFFFFFF;   // 29 bits
inline constexpr std::size_t kMaxDataLength = 8;              // classic CAN
inline constexpr std::size_t kMaxFdDataLength = 64;           // CAN-FD

struct CanFrame {
  std::uint32_t id = 0;       // 11-bit (standard) or 29-bit (extended) identifier, no flag bits
  bool extended = false;      // 29-bit identifier
  bool remote = false;        // remote transmission request (no data)
  bool error = false;         // an error frame reported by the controller: id holds the error class bits
  bool fd = false;            // a CAN-FD frame: up to 64 data bytes, never remote
  bool bit_rate_switch = false;  // FD only: the data phase at the faster data bit rate (CANFD_BRS)
  std::uint8_t length = 0;    // 0..8 data bytes (classic); 0..8, 12, 16, 20, 24, 32, 48, 64 (FD)
  std::array<std::uint8_t, kMaxFdDataLength> data{};

  // Equal when the header and the first `length` data bytes are (bytes beyond the length carry nothing).
  bool operator==(const CanFrame& other) const;
};

// The data lengths a CAN-FD frame can have (its DLC codes 0..15), and the smallest of them holding n bytes
// (n <= 64): a protocol pads its payload up to it.
bool is_fd_length(std::size_t n);
std::uint8_t fd_length_for(std::size_t n);

// Why a frame cannot go on a CAN bus (id too wide, a classic length over 8, an FD length that is no DLC,
// a remote FD frame), or nullopt when it can.
std::optional<std::string> frame_problem(const CanFrame& frame);

// Accepts a data frame when (frame.id & mask) == (id & mask) and the id width matches, like
// SocketCAN's CAN_RAW_FILTER with the EFF flag in the mask. Error frames are never filtered by these:
// they are switched on or off as a whole (CanBus::set_error_frames).
struct CanFilter {
  std::uint32_t id = 0;
  std::uint32_t mask = 0;
  bool extended = false;

  bool matches(const CanFrame& frame) const {
    return frame.extended == extended && (frame.id & mask) == (id & mask);
  }
};

// "123#0102" style text for logs and test failure messages (the notation of can-utils' candump; FD frames
// as "123##<flags>0102", flags 1 = bit rate switch).
std::string to_string(const CanFrame& frame);

}  // namespace cpgmatch::can

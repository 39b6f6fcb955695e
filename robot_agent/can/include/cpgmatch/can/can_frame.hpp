// A classic CAN frame (up to 8 data bytes) and a receive filter, independent of any backend.
//
// The fields mirror Linux's struct can_frame (linux/can.h) without its flag bits packed into the id, so
// code above the bus never depends on kernel headers; the SocketCAN backend and the UDP wire format map
// them back to CAN_EFF_FLAG / CAN_RTR_FLAG / CAN_ERR_FLAG.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

namespace cpgmatch::can {

inline constexpr std::uint32_t kMaxStandardId = 0x7FF;        // 11 bits
inline constexpr std::uint32_t kMaxExtendedId = 0x1FFFFFFF;   // 29 bits
inline constexpr std::size_t kMaxDataLength = 8;              // classic CAN

struct CanFrame {
  std::uint32_t id = 0;       // 11-bit (standard) or 29-bit (extended) identifier, no flag bits
  bool extended = false;      // 29-bit identifier
  bool remote = false;        // remote transmission request (no data)
  bool error = false;         // an error frame reported by the controller: id holds the error class bits
  std::uint8_t length = 0;    // 0..8 data bytes
  std::array<std::uint8_t, kMaxDataLength> data{};

  bool operator==(const CanFrame&) const = default;
};

// Why a frame cannot go on a classic CAN bus (id too wide, length over 8), or nullopt when it can.
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

// "123#0102" style text for logs and test failure messages (the notation of can-utils' candump).
std::string to_string(const CanFrame& frame);

}  // namespace cpgmatch::can

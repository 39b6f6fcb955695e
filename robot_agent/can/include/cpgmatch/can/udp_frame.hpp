// The UDP wire format of CAN frames (udp: bus URIs). Each datagram carries 1..kMaxFramesPerDatagram
// frames of exactly kUdpFrameSize bytes, laid out like Linux's struct can_frame but with a fixed byte
// order so that both ends may differ in endianness:
//
//   bytes 0..3   can_id, big-endian: bits 0..28 the identifier, bit 31 EFF (29-bit id), bit 30 RTR,
//                bit 29 ERR (error frame), exactly as CAN_EFF_FLAG / CAN_RTR_FLAG / CAN_ERR_FLAG
//   byte  4      len, the data length 0..8 (can_dlc)
//   bytes 5..7   reserved, sent as 0, ignored on receipt
//   bytes 8..15  data; bytes at and beyond len are sent as 0 and ignored on receipt
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "cpgmatch/can/can_frame.hpp"

namespace cpgmatch::can {

inline constexpr std::size_t kUdpFrameSize = 16;
inline constexpr std::size_t kMaxFramesPerDatagram = 32;

inline constexpr std::uint32_t kWireEffFlag = 0x80000000u;
inline constexpr std::uint32_t kWireRtrFlag = 0x40000000u;
inline constexpr std::uint32_t kWireErrFlag = 0x20000000u;

// Writes one frame into exactly kUdpFrameSize bytes.
void encode_udp_frame(const CanFrame& frame, std::span<std::uint8_t, kUdpFrameSize> out);

// Reads one frame; nullopt with `why` set when the bytes are not a valid classic CAN frame
// (length over 8, a standard id over 11 bits).
std::optional<CanFrame> decode_udp_frame(std::span<const std::uint8_t, kUdpFrameSize> in, const char** why = nullptr);

}  // namespace cpgmatch::can

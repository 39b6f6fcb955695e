// The UDP wire format of CAN frames (udp: bus URIs). Each datagram carries 1..kMaxFramesPerDatagram frame
// records back to back, laid out like Linux's struct can_frame / struct canfd_frame but with a fixed byte
// order so that both ends may differ in endianness:
//
//   bytes 0..3   can_id, big-endian: bits 0..28 the identifier, bit 31 EFF (29-bit id), bit 30 RTR,
//                bit 29 ERR (error frame), exactly as CAN_EFF_FLAG / CAN_RTR_FLAG / CAN_ERR_FLAG
//   byte  4      len, the data length: 0..8 classic, a CAN-FD length (0..8, 12, 16, 20, 24, 32, 48, 64) FD
//   byte  5      flags (version 2 of this format): bit 0 FD, bit 1 BRS (bit rate switch); other bits 0
//   bytes 6..7   reserved, sent as 0, ignored on receipt
//   bytes 8..    data: 8 bytes in a classic record (kUdpFrameSize = 16 in all), 64 in an FD record
//                (kUdpFdFrameSize = 72); bytes at and beyond len are sent as 0 and ignored on receipt
//
// Version 1 (before CAN-FD) sent byte 5 as 0 and only 16-byte records: its datagrams read unchanged.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "cpgmatch/can/can_frame.hpp"

namespace cpgmatch::can {

inline constexpr std::size_t kUdpFrameSize = 16;
inline constexpr std::size_t kUdpFdFrameSize = 72;
inline constexpr std::size_t kMaxFramesPerDatagram = 32;
inline constexpr std::size_t kMaxDatagramSize = kMaxFramesPerDatagram * kUdpFdFrameSize;

inline constexpr std::uint32_t kWireEffFlag = 0x80000000u;
inline constexpr std::uint32_t kWireRtrFlag = 0x40000000u;
inline constexpr std::uint32_t kWireErrFlag = 0x20000000u;
inline constexpr std::uint8_t kWireFdFlag = 0x01;   // byte 5
inline constexpr std::uint8_t kWireBrsFlag = 0x02;  // byte 5

// The record size a frame takes on the wire: kUdpFrameSize or kUdpFdFrameSize.
std::size_t udp_record_size(const CanFrame& frame);

// Writes one classic frame into exactly kUdpFrameSize bytes (an FD frame needs encode_udp_record).
void encode_udp_frame(const CanFrame& frame, std::span<std::uint8_t, kUdpFrameSize> out);
// Writes one frame of either kind at the start of `out` (at least udp_record_size(frame) bytes) and
// returns the bytes written.
std::size_t encode_udp_record(const CanFrame& frame, std::span<std::uint8_t> out);

// Reads one classic record; nullopt with `why` set when the bytes are not a valid classic CAN frame
// (length over 8, a standard id over 11 bits, the FD flag set).
std::optional<CanFrame> decode_udp_frame(std::span<const std::uint8_t, kUdpFrameSize> in, const char** why = nullptr);
// Reads the record at the start of `in` (classic or FD, from its flags) and sets `consumed` to its size;
// nullopt with `why` set for an invalid or truncated record.
std::optional<CanFrame> decode_udp_record(std::span<const std::uint8_t> in, std::size_t& consumed,
                                          const char** why = nullptr);

}  // namespace cpgmatch::can

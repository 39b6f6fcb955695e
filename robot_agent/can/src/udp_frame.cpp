#include "cpgmatch/can/udp_frame.hpp"

#include <algorithm>

namespace cpgmatch::can {

std::size_t udp_record_size(const CanFrame& frame) { return frame.fd ? kUdpFdFrameSize : kUdpFrameSize; }

std::size_t encode_udp_record(const CanFrame& frame, std::span<std::uint8_t> out) {
  const std::size_t size = udp_record_size(frame);
  std::uint32_t id = frame.id & (frame.extended || frame.error ? kMaxExtendedId : kMaxStandardId);
  if (frame.extended) id |= kWireEffFlag;
  if (frame.remote) id |= kWireRtrFlag;
  if (frame.error) id |= kWireErrFlag;
  std::fill(out.begin(), out.begin() + size, std::uint8_t{0});
  out[0] = static_cast<std::uint8_t>(id >> 24);
  out[1] = static_cast<std::uint8_t>(id >> 16);
  out[2] = static_cast<std::uint8_t>(id >> 8);
  out[3] = static_cast<std::uint8_t>(id);
  const std::uint8_t length = std::min<std::uint8_t>(frame.length, static_cast<std::uint8_t>(size - 8));
  out[4] = length;
  if (frame.fd) out[5] = static_cast<std::uint8_t>(kWireFdFlag | (frame.bit_rate_switch ? kWireBrsFlag : 0));
  std::copy_n(frame.data.begin(), length, out.begin() + 8);
  return size;
}

void encode_udp_frame(const CanFrame& frame, std::span<std::uint8_t, kUdpFrameSize> out) {
  CanFrame classic = frame;
  classic.fd = false;
  classic.bit_rate_switch = false;
  encode_udp_record(classic, out);
}

std::optional<CanFrame> decode_udp_record(std::span<const std::uint8_t> in, std::size_t& consumed, const char** why) {
  consumed = 0;
  if (in.size() < kUdpFrameSize) {
    if (why) *why = "truncated frame record";
    return std::nullopt;
  }
  const std::uint8_t flags = in[5];
  const bool fd = (flags & kWireFdFlag) != 0;
  const std::size_t size = fd ? kUdpFdFrameSize : kUdpFrameSize;
  if (in.size() < size) {
    if (why) *why = "truncated CAN-FD frame record";
    return std::nullopt;
  }
  if ((flags & ~(kWireFdFlag | kWireBrsFlag)) != 0 || (!fd && (flags & kWireBrsFlag))) {
    if (why) *why = "unknown flags";
    return std::nullopt;
  }
  const std::uint32_t raw = (std::uint32_t{in[0]} << 24) | (std::uint32_t{in[1]} << 16) |
                            (std::uint32_t{in[2]} << 8) | std::uint32_t{in[3]};
  CanFrame frame;
  frame.extended = (raw & kWireEffFlag) != 0;
  frame.remote = (raw & kWireRtrFlag) != 0;
  frame.error = (raw & kWireErrFlag) != 0;
  frame.fd = fd;
  frame.bit_rate_switch = (flags & kWireBrsFlag) != 0;
  frame.id = raw & kMaxExtendedId;
  if (!frame.extended && !frame.error && frame.id > kMaxStandardId) {
    if (why) *why = "standard frame with an id over 11 bits";
    return std::nullopt;
  }
  if (!fd && in[4] > kMaxDataLength) {
    if (why) *why = "data length over 8";
    return std::nullopt;
  }
  if (fd && (!is_fd_length(in[4]) || frame.remote)) {
    if (why) *why = frame.remote ? "remote CAN-FD frame" : "data length that is no CAN-FD length";
    return std::nullopt;
  }
  frame.length = in[4];
  std::copy_n(in.begin() + 8, frame.length, frame.data.begin());
  consumed = size;
  return frame;
}

std::optional<CanFrame> decode_udp_frame(std::span<const std::uint8_t, kUdpFrameSize> in, const char** why) {
  if (in[5] & kWireFdFlag) {
    if (why) *why = "a CAN-FD record does not fit 16 bytes";
    return std::nullopt;
  }
  std::size_t consumed = 0;
  return decode_udp_record(std::span<const std::uint8_t>(in.data(), in.size()), consumed, why);
}

}  // namespace cpgmatch::can

#include "cpgmatch/can/udp_frame.hpp"

#include <algorithm>

namespace cpgmatch::can {

void encode_udp_frame(const CanFrame& frame, std::span<std::uint8_t, kUdpFrameSize> out) {
  std::uint32_t id = frame.id & (frame.extended || frame.error ? kMaxExtendedId : kMaxStandardId);
  if (frame.extended) id |= kWireEffFlag;
  if (frame.remote) id |= kWireRtrFlag;
  if (frame.error) id |= kWireErrFlag;
  std::fill(out.begin(), out.end(), std::uint8_t{0});
  out[0] = static_cast<std::uint8_t>(id >> 24);
  out[1] = static_cast<std::uint8_t>(id >> 16);
  out[2] = static_cast<std::uint8_t>(id >> 8);
  out[3] = static_cast<std::uint8_t>(id);
  const std::uint8_t length = std::min<std::uint8_t>(frame.length, kMaxDataLength);
  out[4] = length;
  std::copy_n(frame.data.begin(), length, out.begin() + 8);
}

std::optional<CanFrame> decode_udp_frame(std::span<const std::uint8_t, kUdpFrameSize> in, const char** why) {
  const std::uint32_t raw = (std::uint32_t{in[0]} << 24) | (std::uint32_t{in[1]} << 16) |
                            (std::uint32_t{in[2]} << 8) | std::uint32_t{in[3]};
  CanFrame frame;
  frame.extended = (raw & kWireEffFlag) != 0;
  frame.remote = (raw & kWireRtrFlag) != 0;
  frame.error = (raw & kWireErrFlag) != 0;
  frame.id = raw & kMaxExtendedId;
  if (!frame.extended && !frame.error && frame.id > kMaxStandardId) {
    if (why) *why = "standard frame with an id over 11 bits";
    return std::nullopt;
  }
  if (in[4] > kMaxDataLength) {
    if (why) *why = "data length over 8";
    return std::nullopt;
  }
  frame.length = in[4];
  std::copy_n(in.begin() + 8, frame.length, frame.data.begin());
  return frame;
}

}  // namespace cpgmatch::can

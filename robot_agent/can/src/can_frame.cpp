#include "cpgmatch/can/can_frame.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace cpgmatch::can {

bool CanFrame::operator==(const CanFrame& o) const {
  if (id != o.id || extended != o.extended || remote != o.remote || error != o.error || fd != o.fd ||
      bit_rate_switch != o.bit_rate_switch || length != o.length) {
    return false;
  }
  const std::size_t n = std::min<std::size_t>(length, kMaxFdDataLength);
  return std::equal(data.begin(), data.begin() + n, o.data.begin());
}

bool is_fd_length(std::size_t n) {
  return n <= 8 || n == 12 || n == 16 || n == 20 || n == 24 || n == 32 || n == 48 || n == 64;
}

std::uint8_t fd_length_for(std::size_t n) {
  for (const std::size_t length : {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64}) {
    if (length >= n) return static_cast<std::uint8_t>(length);
  }
  return static_cast<std::uint8_t>(kMaxFdDataLength);
}

std::optional<std::string> frame_problem(const CanFrame& frame) {
  if (frame.fd) {
    if (frame.remote) return std::string("a CAN-FD frame cannot be a remote request");
    if (!is_fd_length(frame.length)) {
      return fmt::format("data length {} is not a CAN-FD length (0..8, 12, 16, 20, 24, 32, 48, 64)", frame.length);
    }
  } else {
    if (frame.bit_rate_switch) return std::string("bit rate switch on a classic frame");
    if (frame.length > kMaxDataLength) return fmt::format("data length {} is over {}", frame.length, kMaxDataLength);
  }
  const std::uint32_t max_id = frame.extended ? kMaxExtendedId : kMaxStandardId;
  if (frame.id > max_id) {
    return fmt::format("id 0x{:X} does not fit a {} identifier", frame.id, frame.extended ? "29-bit" : "11-bit");
  }
  return std::nullopt;
}

std::string to_string(const CanFrame& frame) {
  std::string text = frame.extended ? fmt::format("{:08X}#", frame.id) : fmt::format("{:03X}#", frame.id);
  if (frame.error) text = "ERR:" + text;
  if (frame.remote) return text + "R";
  if (frame.fd) text += fmt::format("#{:X}", frame.bit_rate_switch ? 1 : 0);
  const std::size_t limit = frame.fd ? kMaxFdDataLength : kMaxDataLength;
  for (std::size_t i = 0; i < frame.length && i < limit; ++i) text += fmt::format("{:02X}", frame.data[i]);
  return text;
}

}  // namespace cpgmatch::can

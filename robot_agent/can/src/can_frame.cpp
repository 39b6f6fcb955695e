#include "cpgmatch/can/can_frame.hpp"

#include <fmt/format.h>

namespace cpgmatch::can {

std::optional<std::string> frame_problem(const CanFrame& frame) {
  if (frame.length > kMaxDataLength) return fmt::format("data length {} is over {}", frame.length, kMaxDataLength);
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
  for (int i = 0; i < frame.length && i < static_cast<int>(kMaxDataLength); ++i) text += fmt::format("{:02X}", frame.data[i]);
  return text;
}

}  // namespace cpgmatch::can

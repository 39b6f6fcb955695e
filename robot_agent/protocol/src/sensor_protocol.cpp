#include "cpgmatch/robot/sensor_protocol.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cpgmatch::robot {
namespace {

// Scales and clamps into an integer type's range; NaN becomes 0.
template <typename Int>
Int scaled(double value, double unit) {
  if (std::isnan(value)) return 0;
  const double raw = std::round(value / unit);
  return static_cast<Int>(std::clamp(raw, static_cast<double>(std::numeric_limits<Int>::min()),
                                     static_cast<double>(std::numeric_limits<Int>::max())));
}

void put16(can::CanFrame& f, int at, std::uint16_t v) {
  f.data[at] = static_cast<std::uint8_t>(v >> 8);
  f.data[at + 1] = static_cast<std::uint8_t>(v & 0xFF);
}
std::uint16_t get16(const can::CanFrame& f, int at) {
  return static_cast<std::uint16_t>((f.data[at] << 8) | f.data[at + 1]);
}

bool is_data_frame(const can::CanFrame& f, std::uint32_t id, std::uint8_t length) {
  return !f.error && !f.remote && !f.extended && !f.fd && f.id == id && f.length == length;
}

}  // namespace

can::CanFrame encode_foot(std::uint32_t node_id, const FootReading& r) {
  can::CanFrame f;
  f.id = node_id;
  f.length = kFootFrameLength;
  put16(f, 0, scaled<std::uint16_t>(r.force_n, 0.01));
  f.data[2] = r.sequence;
  f.data[3] = r.fault ? 1 : 0;
  return f;
}

std::optional<FootReading> decode_foot(const can::CanFrame& f, std::uint32_t node_id) {
  if (!is_data_frame(f, node_id, kFootFrameLength)) return std::nullopt;
  FootReading r;
  r.force_n = get16(f, 0) * 0.01;
  r.sequence = f.data[2];
  r.fault = (f.data[3] & 1) != 0;
  return r;
}

can::CanFrame encode_trunk_pose(std::uint32_t node_id, const TrunkReading& r) {
  can::CanFrame f;
  f.id = node_id;
  f.length = kTrunkPoseLength;
  const auto x = static_cast<std::uint32_t>(scaled<std::int32_t>(r.x_m, 1e-5));
  f.data[0] = static_cast<std::uint8_t>(x >> 24);
  f.data[1] = static_cast<std::uint8_t>(x >> 16);
  f.data[2] = static_cast<std::uint8_t>(x >> 8);
  f.data[3] = static_cast<std::uint8_t>(x);
  put16(f, 4, static_cast<std::uint16_t>(scaled<std::int16_t>(r.pitch_rad, 1e-4)));
  put16(f, 6, scaled<std::uint16_t>(r.height_m, 1e-5));
  return f;
}

std::optional<TrunkReading> decode_trunk_pose(const can::CanFrame& f, std::uint32_t node_id) {
  if (!is_data_frame(f, node_id, kTrunkPoseLength)) return std::nullopt;
  const std::uint32_t x = (std::uint32_t{f.data[0]} << 24) | (std::uint32_t{f.data[1]} << 16) |
                          (std::uint32_t{f.data[2]} << 8) | f.data[3];
  TrunkReading r;
  r.x_m = static_cast<std::int32_t>(x) * 1e-5;
  r.pitch_rad = static_cast<std::int16_t>(get16(f, 4)) * 1e-4;
  r.height_m = get16(f, 6) * 1e-5;
  return r;
}

can::CanFrame encode_trunk_speed(std::uint32_t frame_id, double vx_mps) {
  can::CanFrame f;
  f.id = frame_id;
  f.length = kTrunkSpeedLength;
  put16(f, 0, static_cast<std::uint16_t>(scaled<std::int16_t>(vx_mps, 1e-3)));
  return f;
}

std::optional<double> decode_trunk_speed(const can::CanFrame& f, std::uint32_t frame_id) {
  if (!is_data_frame(f, frame_id, kTrunkSpeedLength)) return std::nullopt;
  return static_cast<std::int16_t>(get16(f, 0)) * 1e-3;
}

}  // namespace cpgmatch::robot

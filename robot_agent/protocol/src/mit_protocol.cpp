#include "cpgmatch/robot/mit_protocol.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cpgmatch::robot {

std::uint32_t mit_float_to_uint(double x, double low, double high, int bits) {
  if (std::isnan(x)) x = 0.0;
  x = std::clamp(x, low, high);
  const double steps = static_cast<double>((1u << bits) - 1u);
  return static_cast<std::uint32_t>(std::lround((x - low) * steps / (high - low)));
}

double mit_uint_to_float(std::uint32_t u, double low, double high, int bits) {
  const double steps = static_cast<double>((1u << bits) - 1u);
  return low + static_cast<double>(u) * (high - low) / steps;
}

can::CanFrame mit_encode_command(std::uint32_t node_id, const MotorCommand& c, const MitRanges& r) {
  std::uint32_t p = mit_float_to_uint(c.position_rad, -r.position_max_rad, r.position_max_rad, kMitPositionBits);
  const std::uint32_t v = mit_float_to_uint(c.velocity_rad_s, -r.velocity_max_rad_s, r.velocity_max_rad_s, kMitVelocityBits);
  const std::uint32_t kp = mit_float_to_uint(c.kp_nm_per_rad, 0.0, r.kp_max_nm_per_rad, kMitGainBits);
  const std::uint32_t kd = mit_float_to_uint(c.kd_nm_s_per_rad, 0.0, r.kd_max_nm_s_per_rad, kMitGainBits);
  const std::uint32_t t = mit_float_to_uint(c.torque_nm, -r.torque_max_nm, r.torque_max_nm, kMitTorqueBits);
  // Every value at its maximum with t_ff >= 0xFFC would read as a special frame (enter/exit/zero) on
  // the motor; one position step less keeps a command a command.
  if (p == 0xFFFF && v == 0xFFF && kp == 0xFFF && kd == 0xFFF && t >= 0xFFC) p = 0xFFFE;
  can::CanFrame f;
  f.id = node_id;
  f.length = kMitCommandLength;
  f.data[0] = static_cast<std::uint8_t>(p >> 8);
  f.data[1] = static_cast<std::uint8_t>(p & 0xFF);
  f.data[2] = static_cast<std::uint8_t>(v >> 4);
  f.data[3] = static_cast<std::uint8_t>(((v & 0xF) << 4) | (kp >> 8));
  f.data[4] = static_cast<std::uint8_t>(kp & 0xFF);
  f.data[5] = static_cast<std::uint8_t>(kd >> 4);
  f.data[6] = static_cast<std::uint8_t>(((kd & 0xF) << 4) | (t >> 8));
  f.data[7] = static_cast<std::uint8_t>(t & 0xFF);
  return f;
}

can::CanFrame mit_special_frame(std::uint32_t node_id, MitSpecial which) {
  can::CanFrame f;
  f.id = node_id;
  f.length = kMitCommandLength;
  std::fill_n(f.data.begin(), kMitCommandLength, std::uint8_t{0xFF});
  f.data[7] = static_cast<std::uint8_t>(which);
  return f;
}

std::optional<MotorFeedback> mit_decode_reply(const can::CanFrame& f, std::uint32_t host_id, const MitRanges& r) {
  if (f.error || f.remote || f.extended || f.fd || f.id != host_id || f.length != kMitReplyLength) return std::nullopt;
  const std::uint32_t p = (std::uint32_t{f.data[1]} << 8) | f.data[2];
  const std::uint32_t v = (std::uint32_t{f.data[3]} << 4) | (f.data[4] >> 4);
  const std::uint32_t t = ((std::uint32_t{f.data[4]} & 0xF) << 8) | f.data[5];
  MotorFeedback fb;
  fb.node_id = f.data[0];
  fb.position_rad = mit_uint_to_float(p, -r.position_max_rad, r.position_max_rad, kMitPositionBits);
  fb.velocity_rad_s = mit_uint_to_float(v, -r.velocity_max_rad_s, r.velocity_max_rad_s, kMitVelocityBits);
  fb.torque_nm = mit_uint_to_float(t, -r.torque_max_nm, r.torque_max_nm, kMitTorqueBits);
  return fb;
}

std::optional<MitReceived> mit_decode_command(const can::CanFrame& f, const MitRanges& r) {
  if (f.error || f.remote || f.extended || f.fd || f.length != kMitCommandLength) return std::nullopt;
  MitReceived received;
  if (std::all_of(f.data.begin(), f.data.begin() + 7, [](std::uint8_t b) { return b == 0xFF; })) {
    switch (f.data[7]) {
      case 0xFC: received.kind = MitReceived::Kind::kEnterMotorMode; return received;
      case 0xFD: received.kind = MitReceived::Kind::kExitMotorMode; return received;
      case 0xFE: received.kind = MitReceived::Kind::kSetZero; return received;
      default: break;
    }
  }
  const std::uint32_t p = (std::uint32_t{f.data[0]} << 8) | f.data[1];
  const std::uint32_t v = (std::uint32_t{f.data[2]} << 4) | (f.data[3] >> 4);
  const std::uint32_t kp = ((std::uint32_t{f.data[3]} & 0xF) << 8) | f.data[4];
  const std::uint32_t kd = (std::uint32_t{f.data[5]} << 4) | (f.data[6] >> 4);
  const std::uint32_t t = ((std::uint32_t{f.data[6]} & 0xF) << 8) | f.data[7];
  MotorCommand& c = received.command;
  c.position_rad = mit_uint_to_float(p, -r.position_max_rad, r.position_max_rad, kMitPositionBits);
  c.velocity_rad_s = mit_uint_to_float(v, -r.velocity_max_rad_s, r.velocity_max_rad_s, kMitVelocityBits);
  c.kp_nm_per_rad = mit_uint_to_float(kp, 0.0, r.kp_max_nm_per_rad, kMitGainBits);
  c.kd_nm_s_per_rad = mit_uint_to_float(kd, 0.0, r.kd_max_nm_s_per_rad, kMitGainBits);
  c.torque_nm = mit_uint_to_float(t, -r.torque_max_nm, r.torque_max_nm, kMitTorqueBits);
  return received;
}

can::CanFrame mit_encode_reply(std::uint32_t host_id, const MotorFeedback& fb, const MitRanges& r) {
  const std::uint32_t p = mit_float_to_uint(fb.position_rad, -r.position_max_rad, r.position_max_rad, kMitPositionBits);
  const std::uint32_t v = mit_float_to_uint(fb.velocity_rad_s, -r.velocity_max_rad_s, r.velocity_max_rad_s, kMitVelocityBits);
  const std::uint32_t t = mit_float_to_uint(fb.torque_nm, -r.torque_max_nm, r.torque_max_nm, kMitTorqueBits);
  can::CanFrame f;
  f.id = host_id;
  f.length = kMitReplyLength;
  f.data[0] = static_cast<std::uint8_t>(fb.node_id);
  f.data[1] = static_cast<std::uint8_t>(p >> 8);
  f.data[2] = static_cast<std::uint8_t>(p & 0xFF);
  f.data[3] = static_cast<std::uint8_t>(v >> 4);
  f.data[4] = static_cast<std::uint8_t>(((v & 0xF) << 4) | (t >> 8));
  f.data[5] = static_cast<std::uint8_t>(t & 0xFF);
  return f;
}

MitMotor::MitMotor(std::uint32_t node_id, std::uint32_t host_id, const MitRanges& ranges)
    : node_id_(node_id), host_id_(host_id), ranges_(ranges) {
  // The reply carries the node id in one byte; ids must also fit an 11-bit CAN identifier.
  if (node_id < 1 || node_id > 0xFF) throw std::invalid_argument("MIT node id must be in 1..255");
  if (host_id > can::kMaxStandardId) throw std::invalid_argument("MIT host id must fit 11 bits");
}

can::CanFrame MitMotor::command(const MotorCommand& c) const { return mit_encode_command(node_id_, c, ranges_); }
can::CanFrame MitMotor::enable() const { return mit_special_frame(node_id_, MitSpecial::kEnterMotorMode); }
can::CanFrame MitMotor::disable() const { return mit_special_frame(node_id_, MitSpecial::kExitMotorMode); }
can::CanFrame MitMotor::set_zero() const { return mit_special_frame(node_id_, MitSpecial::kSetZero); }

FeedbackResult MitMotor::decode(const can::CanFrame& f) const {
  FeedbackResult result;
  if (f.error || f.remote || f.extended || f.fd || f.id != host_id_) return result;  // not a reply at all
  if (f.length != kMitReplyLength) {
    result.status = FeedbackStatus::kWrongLength;
    return result;
  }
  if (f.data[0] != node_id_) return result;  // another motor's reply
  result.feedback = *mit_decode_reply(f, host_id_, ranges_);
  result.status = FeedbackStatus::kOk;
  result.has_position = true;
  result.has_torque = true;
  return result;
}

can::CanFilter MitMotor::feedback_filter() const { return {host_id_, can::kMaxStandardId, false}; }

}  // namespace cpgmatch::robot

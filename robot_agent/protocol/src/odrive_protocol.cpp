#include "cpgmatch/robot/odrive_protocol.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace cpgmatch::robot {
namespace {

constexpr float kUnknown = std::numeric_limits<float>::quiet_NaN();

can::CanFrame frame_for(std::uint32_t node, std::uint32_t cmd, std::uint8_t length) {
  can::CanFrame f;
  f.id = odrive_id(node, cmd);
  f.length = length;
  return f;
}

// A feed-forward in units of 0.001, clamped to int16 (NaN: 0).
std::int16_t milli16(double value) {
  if (std::isnan(value)) return 0;
  return static_cast<std::int16_t>(std::clamp(std::lround(value * 1000.0), -32768L, 32767L));
}

void put_i16(can::CanFrame& f, int at, std::int16_t v) {
  const auto u = static_cast<std::uint16_t>(v);
  f.data[at] = static_cast<std::uint8_t>(u & 0xFF);
  f.data[at + 1] = static_cast<std::uint8_t>(u >> 8);
}
std::int16_t get_i16(const can::CanFrame& f, int at) {
  return static_cast<std::int16_t>(static_cast<std::uint16_t>(f.data[at] | (f.data[at + 1] << 8)));
}

bool plain_data(const can::CanFrame& f) { return !f.error && !f.remote && !f.extended && !f.fd; }

}  // namespace

void odrive_put_u32(can::CanFrame& f, int at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) f.data[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
std::uint32_t odrive_get_u32(const can::CanFrame& f, int at) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= std::uint32_t{f.data[at + i]} << (8 * i);
  return v;
}
void odrive_put_f32(can::CanFrame& f, int at, float v) { odrive_put_u32(f, at, std::bit_cast<std::uint32_t>(v)); }
float odrive_get_f32(const can::CanFrame& f, int at) { return std::bit_cast<float>(odrive_get_u32(f, at)); }

can::CanFrame odrive_set_input_pos(std::uint32_t node, double pos_rad, double vel_ff_rad_s, double torque_ff_nm) {
  can::CanFrame f = frame_for(node, kOdriveSetInputPos, 8);
  odrive_put_f32(f, 0, std::isfinite(pos_rad) ? static_cast<float>(odrive_rad_to_rev(pos_rad)) : 0.0f);
  put_i16(f, 4, milli16(odrive_rad_to_rev(vel_ff_rad_s)));
  put_i16(f, 6, milli16(torque_ff_nm));
  return f;
}

can::CanFrame odrive_set_axis_state(std::uint32_t node, std::uint32_t state) {
  can::CanFrame f = frame_for(node, kOdriveSetAxisState, 4);
  odrive_put_u32(f, 0, state);
  return f;
}

can::CanFrame odrive_float_frame(std::uint32_t node, std::uint32_t cmd, float a) {
  can::CanFrame f = frame_for(node, cmd, 4);
  odrive_put_f32(f, 0, a);
  return f;
}

can::CanFrame odrive_two_floats(std::uint32_t node, std::uint32_t cmd, float a, float b) {
  can::CanFrame f = frame_for(node, cmd, 8);
  odrive_put_f32(f, 0, a);
  odrive_put_f32(f, 4, b);
  return f;
}

can::CanFrame odrive_heartbeat(std::uint32_t node, std::uint32_t axis_error, std::uint32_t axis_state) {
  can::CanFrame f = frame_for(node, kOdriveHeartbeat, 8);
  odrive_put_u32(f, 0, axis_error);
  f.data[4] = static_cast<std::uint8_t>(axis_state);
  return f;
}

can::CanFrame odrive_encoder_estimates(std::uint32_t node, double pos_rad, double vel_rad_s) {
  return odrive_two_floats(node, kOdriveEncoderEstimates, static_cast<float>(odrive_rad_to_rev(pos_rad)),
                           static_cast<float>(odrive_rad_to_rev(vel_rad_s)));
}

can::CanFrame odrive_iq(std::uint32_t node, double iq_setpoint_a, double iq_measured_a) {
  return odrive_two_floats(node, kOdriveGetIq, static_cast<float>(iq_setpoint_a), static_cast<float>(iq_measured_a));
}

std::optional<OdriveInputPos> odrive_decode_input_pos(const can::CanFrame& f) {
  if (!plain_data(f) || f.length != 8) return std::nullopt;
  OdriveInputPos p;
  p.pos_rad = odrive_rev_to_rad(odrive_get_f32(f, 0));
  p.vel_ff_rad_s = odrive_rev_to_rad(get_i16(f, 4) * 0.001);
  p.torque_ff_nm = get_i16(f, 6) * 0.001;
  return p;
}

OdriveMotor::OdriveMotor(std::uint32_t node_id, const OdriveSettings& settings)
    : node_(node_id), settings_(settings), pos_gain_sent_(kUnknown), vel_gain_sent_(kUnknown) {
  if (node_id > kOdriveMaxNode) throw std::invalid_argument("ODrive node id must be in 0..63");
  if (settings.request_iq && !(settings.torque_constant_nm_per_a > 0.0)) {
    throw std::invalid_argument("ODrive torque feedback needs a torque constant > 0");
  }
}

std::pair<float, float> OdriveMotor::gains_for(double kp, double kd) {
  kp = std::isfinite(kp) ? std::max(kp, 0.0) : 0.0;
  kd = std::isfinite(kd) ? std::max(kd, 0.0) : 0.0;
  // kd [N m s/rad] -> vel_gain [N m/(rev/s)]: one rev/s is 2 pi rad/s. pos_gain = kp / kd has units 1/s
  // in either angle unit. Without damping the cascade cannot hold stiffness: no position gain either.
  const double vel_gain = kd * 2.0 * kPi;
  const double pos_gain = kd > 0.0 ? kp / kd : 0.0;
  return {static_cast<float>(pos_gain), static_cast<float>(vel_gain)};
}

void OdriveMotor::send_gains(double kp, double kd, FrameSink& out) {
  const auto [pos_gain, vel_gain] = gains_for(kp, kd);
  // NaN never equals: unknown gains always go out.
  if (pos_gain_sent_.load(std::memory_order_relaxed) == pos_gain && vel_gain_sent_.load(std::memory_order_relaxed) == vel_gain) return;
  out.push(odrive_float_frame(node_, kOdriveSetPosGain, pos_gain));
  out.push(odrive_two_floats(node_, kOdriveSetVelGains, vel_gain, 0.0f));  // no integrator: a pure impedance
  pos_gain_sent_.store(pos_gain, std::memory_order_relaxed);
  vel_gain_sent_.store(vel_gain, std::memory_order_relaxed);
}

void OdriveMotor::command(const MotorCommand& c, FrameSink& out) {
  send_gains(c.kp_nm_per_rad, c.kd_nm_s_per_rad, out);
  out.push(odrive_set_input_pos(node_, c.position_rad, c.velocity_rad_s, c.torque_nm));
  const std::uint32_t n = commands_.fetch_add(1, std::memory_order_relaxed);
  if (settings_.request_iq && (n + node_) % std::max<std::uint32_t>(settings_.iq_every, 1) == 0) {
    can::CanFrame rtr = frame_for(node_, kOdriveGetIq, 8);
    rtr.remote = true;
    out.push(rtr);
  }
}

void OdriveMotor::enable(FrameSink& out) {
  closed_loop_seen_ = false;
  enabled_ = true;
  can::CanFrame clear = frame_for(node_, kOdriveClearErrors, 1);
  out.push(clear);
  can::CanFrame mode = frame_for(node_, kOdriveSetControllerMode, 8);
  odrive_put_u32(mode, 0, kOdriveControlPosition);
  odrive_put_u32(mode, 4, kOdriveInputPassthrough);
  out.push(mode);
  // Limp until the first command sets the joint's gains: closed loop with zero gains makes no torque
  // (the input position starts at the measured one on entering closed loop).
  pos_gain_sent_ = kUnknown;
  vel_gain_sent_ = kUnknown;
  send_gains(0.0, 0.0, out);
  out.push(odrive_set_axis_state(node_, kOdriveAxisClosedLoop));
}

void OdriveMotor::disable(FrameSink& out) {
  enabled_ = false;
  out.push(odrive_set_axis_state(node_, kOdriveAxisIdle));
}

void OdriveMotor::set_zero(FrameSink& out) { out.push(odrive_float_frame(node_, kOdriveSetAbsolutePosition, 0.0f)); }

FeedbackResult OdriveMotor::decode_feedback(const can::CanFrame& f) {
  FeedbackResult r;
  if (f.error || f.extended || f.fd || (f.id >> 5) != node_ || f.remote) return r;
  const std::uint32_t cmd = f.id & 0x1F;
  if (cmd != kOdriveEncoderEstimates && cmd != kOdriveGetIq && cmd != kOdriveHeartbeat) return r;  // a command
  if (f.length != 8) {
    r.status = FeedbackStatus::kWrongLength;
    return r;
  }
  r.feedback.node_id = node_;
  switch (cmd) {
    case kOdriveEncoderEstimates: {
      const double pos = odrive_get_f32(f, 0), vel = odrive_get_f32(f, 4);
      if (!std::isfinite(pos) || !std::isfinite(vel)) {
        r.status = FeedbackStatus::kMalformed;
        return r;
      }
      r.feedback.position_rad = odrive_rev_to_rad(pos);
      r.feedback.velocity_rad_s = odrive_rev_to_rad(vel);
      r.has_position = true;
      break;
    }
    case kOdriveGetIq: {
      const double iq = odrive_get_f32(f, 4);
      if (!std::isfinite(iq)) {
        r.status = FeedbackStatus::kMalformed;
        return r;
      }
      r.feedback.torque_nm = iq * settings_.torque_constant_nm_per_a;
      r.has_torque = true;
      break;
    }
    default: {  // heartbeat
      const std::uint32_t error = odrive_get_u32(f, 0);
      const std::uint32_t state = f.data[4];
      if (error != 0) {
        r.fault = error;
        r.fault_kind = "axis error";
      } else if (state == kOdriveAxisClosedLoop) {
        closed_loop_seen_ = true;
      } else if (enabled_.load(std::memory_order_relaxed) && closed_loop_seen_) {
        // In closed loop once and out again without being told: the axis disarmed itself.
        r.fault = state;
        r.fault_kind = "axis left closed loop, now in state";
      }
      break;
    }
  }
  r.status = FeedbackStatus::kOk;
  return r;
}

void OdriveMotor::feedback_filters(std::vector<can::CanFilter>& out) const {
  out.push_back({odrive_id(node_, 0), 0x7E0, false});  // every command id of this node
}

}  // namespace cpgmatch::robot

#include "cpgmatch/robot/motor_twin.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "cpgmatch/robot/mit_protocol.hpp"
#include "cpgmatch/robot/moteus_protocol.hpp"
#include "cpgmatch/robot/odrive_protocol.hpp"

namespace cpgmatch::robot {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

class MitTwin final : public MotorTwin {
 public:
  MitTwin(std::uint32_t node, std::uint32_t host, const MitRanges& ranges) : node_(node), host_(host), ranges_(ranges) {}
  TwinInput receive(const can::CanFrame& f) override {
    TwinInput in;
    if (f.extended || f.fd || f.id != node_) return in;
    const auto got = mit_decode_command(f, ranges_);
    if (!got) {  // wrong length: a real driver ignores it
      in.kind = TwinInput::Kind::kIgnored;
      return in;
    }
    switch (got->kind) {
      case MitReceived::Kind::kEnterMotorMode:
        enabled_ = true;
        in.kind = TwinInput::Kind::kEnable;
        in.reply_owed = true;  // entering motor mode answers with the state
        break;
      case MitReceived::Kind::kExitMotorMode: enabled_ = false; in.kind = TwinInput::Kind::kDisable; break;
      case MitReceived::Kind::kSetZero: in.kind = TwinInput::Kind::kZero; break;
      case MitReceived::Kind::kCommand:
        in.kind = TwinInput::Kind::kCommand;
        in.command = got->command;
        in.has_command = enabled_;  // out of motor mode, commands are ignored
        in.reply_owed = enabled_;
        break;
    }
    return in;
  }
  void reply(const MotorFeedback& state, FrameSink& out) override {
    MotorFeedback fb = state;
    fb.node_id = node_;
    out.push(mit_encode_reply(host_, fb, ranges_));
  }
  bool enabled() const override { return enabled_; }

 private:
  std::uint32_t node_, host_;
  MitRanges ranges_;
  bool enabled_ = false;
};

class OdriveTwin final : public MotorTwin {
 public:
  OdriveTwin(std::uint32_t node, const OdriveSettings& settings) : node_(node), settings_(settings) {}
  TwinInput receive(const can::CanFrame& f) override {
    TwinInput in;
    if (f.extended || f.fd || f.error || (f.id >> 5) != node_) return in;
    in.kind = TwinInput::Kind::kIgnored;
    const std::uint32_t cmd = f.id & 0x1F;
    if (f.remote) {
      if (cmd == kOdriveGetIq) {
        iq_owed_ = true;
        in.kind = TwinInput::Kind::kQuery;
        in.reply_owed = true;
      }
      return in;
    }
    switch (cmd) {
      case kOdriveSetAxisState:
        if (f.length < 4) return in;
        if (odrive_get_u32(f, 0) == kOdriveAxisClosedLoop) {
          // Entering closed loop: input_pos starts at the measured position (no jump), as the firmware does.
          state_ = kOdriveAxisClosedLoop;
          in.kind = TwinInput::Kind::kEnable;
          in.command = current(kNaN, 0.0, 0.0);
          in.has_command = true;
          enable_owed_ = true;
          in.reply_owed = true;
        } else if (odrive_get_u32(f, 0) == kOdriveAxisIdle) {
          state_ = kOdriveAxisIdle;
          in.kind = TwinInput::Kind::kDisable;
        }
        return in;
      case kOdriveSetPosGain:
        if (f.length == 4) pos_gain_ = odrive_get_f32(f, 0);
        return in;
      case kOdriveSetVelGains:
        if (f.length == 8) vel_gain_ = odrive_get_f32(f, 0);  // the integrator gain: the agent sends 0
        return in;
      case kOdriveSetInputPos: {
        const auto p = odrive_decode_input_pos(f);
        if (!p) return in;
        in.kind = TwinInput::Kind::kCommand;
        in.command = current(p->pos_rad, p->vel_ff_rad_s, p->torque_ff_nm);
        in.has_command = state_ == kOdriveAxisClosedLoop;  // an idle axis ignores its input
        return in;
      }
      case kOdriveSetAbsolutePosition: in.kind = TwinInput::Kind::kZero; return in;
      default: return in;  // clear errors, controller mode: nothing the body feels
    }
  }
  void reply(const MotorFeedback& state, FrameSink& out) override {
    if (enable_owed_) {  // the new state shows in the next heartbeat; the twin sends it at once
      out.push(odrive_heartbeat(node_, 0, state_));
      out.push(odrive_encoder_estimates(node_, state.position_rad, state.velocity_rad_s));
      enable_owed_ = false;
    }
    if (iq_owed_ && settings_.torque_constant_nm_per_a > 0.0) {
      const double iq = state.torque_nm / settings_.torque_constant_nm_per_a;
      out.push(odrive_iq(node_, iq, iq));
      iq_owed_ = false;
    }
  }
  void cyclic(const MotorFeedback& state, FrameSink& out) override {
    out.push(odrive_encoder_estimates(node_, state.position_rad, state.velocity_rad_s));
    if (++cycles_ % kHeartbeatEvery == 0) out.push(odrive_heartbeat(node_, 0, state_));
  }
  bool enabled() const override { return state_ == kOdriveAxisClosedLoop; }

 private:
  // The impedance the device's gains amount to (odrive_protocol.hpp): kp = vel_gain pos_gain, kd = vel_gain,
  // with vel_gain per rev/s turned into per rad/s.
  MotorCommand current(double pos, double vel_ff, double torque_ff) const {
    MotorCommand c;
    c.position_rad = pos;
    c.velocity_rad_s = vel_ff;
    c.torque_nm = torque_ff;
    c.kd_nm_s_per_rad = vel_gain_ / (2.0 * kPi);
    c.kp_nm_per_rad = c.kd_nm_s_per_rad * pos_gain_;
    return c;
  }
  static constexpr unsigned kHeartbeatEvery = 50;  // 100 ms at 500 Hz, ODrive's default heartbeat rate
  std::uint32_t node_;
  OdriveSettings settings_;
  std::uint32_t state_ = kOdriveAxisIdle;
  double pos_gain_ = 0.0, vel_gain_ = 0.0;
  bool iq_owed_ = false, enable_owed_ = false;
  unsigned cycles_ = 0;
};

class MoteusTwin final : public MotorTwin {
 public:
  MoteusTwin(std::uint32_t servo, std::uint32_t host, const MoteusSettings& settings)
      : servo_(servo), host_(host), settings_(settings) {}
  TwinInput receive(const can::CanFrame& f) override {
    TwinInput in;
    if (f.error || f.remote || (f.id & 0xFF) != servo_ || ((f.id >> 8) & 0x7F) != host_ || (f.id >> 16) != 0) return in;
    const auto request = moteus_parse_request(f);
    in.kind = TwinInput::Kind::kIgnored;
    if (!request) return in;  // a classic frame or one that does not parse: the servo drops it
    if (request->reply_requested && request->read_count > 0) {
      last_ = *request;
      reply_owed_ = true;
      in.reply_owed = true;
    }
    if (request->set_output_rad) in.kind = TwinInput::Kind::kZero;
    if (!request->mode) return in;
    if (*request->mode == kMoteusModeStopped) {
      in.kind = mode_ == kMoteusModeStopped ? TwinInput::Kind::kIgnored : TwinInput::Kind::kDisable;
      mode_ = kMoteusModeStopped;
      return in;
    }
    if (*request->mode != kMoteusModePosition) return in;  // other modes are not modelled
    in.kind = mode_ == kMoteusModeStopped ? TwinInput::Kind::kEnable : TwinInput::Kind::kCommand;
    mode_ = kMoteusModePosition;
    // torque = kp_scale kp (p_des - p) + kd_scale kd (v_des - v) + ff, kp and kd the servo's own.
    in.command.position_rad = request->position_rad.value_or(kNaN);
    in.command.velocity_rad_s = finite_or_zero(request->velocity_rad_s.value_or(0.0));
    in.command.torque_nm = finite_or_zero(request->torque_nm.value_or(0.0));
    in.command.kp_nm_per_rad = finite_or_zero(request->kp_scale.value_or(1.0)) * settings_.servo_kp_nm_per_rad;
    in.command.kd_nm_s_per_rad = finite_or_zero(request->kd_scale.value_or(1.0)) * settings_.servo_kd_nm_s_per_rad;
    in.has_command = true;
    return in;
  }
  void reply(const MotorFeedback& state, FrameSink& out) override {
    if (!reply_owed_) return;
    MoteusState s;
    s.mode = mode_;
    s.position_rad = state.position_rad;
    s.velocity_rad_s = state.velocity_rad_s;
    s.torque_nm = state.torque_nm;
    out.push(moteus_encode_reply(servo_, host_, last_, s));
    reply_owed_ = false;
  }
  bool enabled() const override { return mode_ == kMoteusModePosition; }

 private:
  static double finite_or_zero(double v) { return std::isfinite(v) ? v : 0.0; }
  std::uint32_t servo_, host_;
  MoteusSettings settings_;
  int mode_ = kMoteusModeStopped;
  MoteusRequest last_;
  bool reply_owed_ = false;
};

}  // namespace

std::unique_ptr<MotorTwin> make_motor_twin(const JointConfig& joint, std::uint32_t host_id) {
  if (joint.protocol == "mit") return std::make_unique<MitTwin>(joint.node_id, host_id, joint.mit_ranges);
  if (joint.protocol == "odrive") return std::make_unique<OdriveTwin>(joint.node_id, joint.odrive);
  if (joint.protocol == "moteus") return std::make_unique<MoteusTwin>(joint.node_id, joint.moteus.host_id, joint.moteus);
  throw std::invalid_argument("no device twin for motor protocol '" + joint.protocol + "'");
}

}  // namespace cpgmatch::robot

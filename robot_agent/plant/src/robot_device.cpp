#include "cpgmatch/robot/robot_device.hpp"

#include <algorithm>
#include <cmath>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot/sensor_protocol.hpp"

namespace cpgmatch::robot {

RobotDevice::RobotDevice(const RobotConfig& config, can::CanBus& bus, DeviceImperfections imperfections)
    : config_(config), bus_(bus), imperfections_(imperfections), rng_(imperfections.seed) {
  if (auto why = config_.plant_mismatch()) throw InputError(*why);
  for (const JointConfig& joint : config_.joints) {
    joints_.push_back(&joint);
    twins_.push_back(make_motor_twin(joint, config_.host_id));
  }
  const std::size_t n = joints_.size();
  commanded_.assign(n, false);
  last_command_.assign(n, MotorCommand{});
  last_command_ns_.assign(n, 0);
  timed_out_.assign(n, false);
  zero_.assign(n, 0.0);
  position_.assign(n, 0.0);
  velocity_.assign(n, 0.0);
  torque_.assign(n, 0.0);
  encoder_.assign(n, 0.0);
  commands_ = PerLeg<JointCommand>(config_.legs.size());
  state_.legs = PerLeg<LegState>(config_.legs.size());
  for (int leg = 0; leg < config_.leg_count(); ++leg) commands_[leg].hip_passive = true;  // motors start off
}

double RobotDevice::gaussian(double sigma) {
  if (sigma <= 0.0) return 0.0;
  return std::normal_distribution<double>(0.0, sigma)(rng_);
}

RobotDevice::Received RobotDevice::receive(std::chrono::nanoseconds timeout) {
  Received result;
  can::CanFrame frame;
  if (!bus_.receive(frame, timeout)) return result;
  result.event = Event::kIgnored;
  for (int j = 0; j < joint_count(); ++j) {
    const TwinInput in = twins_[j]->receive(frame);
    if (in.kind == TwinInput::Kind::kNotMine) continue;
    result.joint = j;
    result.reply_owed = in.reply_owed;
    const JointConfig& joint = *joints_[j];
    const bool hip = joint.role == JointRole::kHip;
    JointCommand& body = commands_[joint.leg];
    switch (in.kind) {
      case TwinInput::Kind::kEnable:
        last_command_ns_[j] = monotonic_ns();  // the watchdog counts from enabling
        result.event = Event::kEnable;
        break;
      case TwinInput::Kind::kDisable:
        if (hip) body.hip_passive = true;
        result.event = Event::kDisable;
        break;
      case TwinInput::Kind::kZero:
        zero_[j] = joint.to_motor_position(position_[j]);
        result.event = Event::kZero;
        break;
      case TwinInput::Kind::kQuery: result.event = Event::kQuery; break;
      case TwinInput::Kind::kCommand: {
        result.event = Event::kCommand;
        if (!in.has_command) break;  // a motor that is off ignores commands
        MotorCommand c = in.command;
        if (!std::isfinite(c.position_rad)) c.position_rad = joint.to_motor_position(position_[j]) - zero_[j];  // hold
        last_command_[j] = c;
        last_command_ns_[j] = monotonic_ns();
        timed_out_[j] = false;
        commanded_[j] = true;
        const double target = joint.to_joint_position(c.position_rad + zero_[j]);
        if (hip) {
          // The body model has its own motor law (the ODE hip PD); kp = kd = 0 is the passive hip, and
          // kp = 0 with damping (the safe state) is passive too: the model has no pure-damping mode.
          body.hip_passive = c.kp_nm_per_rad <= 0.0;
          body.hip_angle_rad = target;
        } else if (c.kp_nm_per_rad > 0.0) {
          body.knee_flexion_rad = target;
        }
        break;
      }
      default: break;
    }
    return result;
  }
  return result;
}

int RobotDevice::enforce_command_timeout(std::int64_t now_ns, std::int64_t timeout_ns) {
  int made_safe = 0;
  for (int j = 0; j < joint_count(); ++j) {
    if (!enabled(j) || timed_out_[j] || now_ns - last_command_ns_[j] < timeout_ns) continue;
    MotorCommand safe;  // kp = 0, feed-forward 0: the motor only damps
    safe.position_rad = last_command_[j].position_rad;
    safe.kd_nm_s_per_rad = joints_[j]->to_motor_kd(config_.safe_damping(*joints_[j]));
    last_command_[j] = safe;
    if (joints_[j]->role == JointRole::kHip) commands_[joints_[j]->leg].hip_passive = true;  // no pure-damping mode
    timed_out_[j] = true;
    ++made_safe;
  }
  return made_safe;
}

bool RobotDevice::all_commanded() const {
  return std::all_of(commanded_.begin(), commanded_.end(), [](bool c) { return c; });
}

void RobotDevice::update(const PlantState& state, double dt_s) {
  for (int j = 0; j < joint_count(); ++j) {
    const JointConfig& joint = *joints_[j];
    const LegState& leg = state.legs[joint.leg];
    const bool hip = joint.role == JointRole::kHip;
    const double position = hip ? leg.hip_angle_rad : leg.knee_flexion_rad;
    velocity_[j] = have_state_ && dt_s > 0.0 ? (position - position_[j]) / dt_s : 0.0;
    position_[j] = position;
    const double play = 0.5 * imperfections_.backlash_rad;
    encoder_[j] = have_state_ ? std::clamp(encoder_[j], position - play, position + play) : position;
    torque_[j] = hip ? leg.hip_torque_nm : leg.knee_torque_nm;
  }
  state_ = state;
  have_state_ = true;
}

MotorFeedback RobotDevice::motor_state(int j) {
  const JointConfig& joint = *joints_[j];
  MotorFeedback fb;
  fb.node_id = joint.node_id;
  fb.position_rad = joint.to_motor_position(encoder_[j] + gaussian(imperfections_.position_noise_rad)) - zero_[j];
  fb.velocity_rad_s = joint.to_motor_velocity(velocity_[j]);
  fb.torque_nm = joint.to_motor_torque(torque_[j]);
  return fb;
}

void RobotDevice::emit_all(const FrameSink& frames, bool motor_feedback) {
  if (frames.size() == 0) return;
  if (motor_feedback && imperfections_.reply_dropout > 0.0 &&
      std::uniform_real_distribution<double>(0, 1)(rng_) < imperfections_.reply_dropout) {
    return;
  }
  for (const can::CanFrame& f : frames.frames()) emit(f);
}

void RobotDevice::reply(int j) {
  out_.clear();
  twins_[j]->reply(motor_state(j), out_);
  emit_all(out_, true);
}

void RobotDevice::reply_all() {
  for (int j = 0; j < joint_count(); ++j) reply(j);
}

void RobotDevice::send_sensors() {
  ++sequence_;
  for (int leg = 0; leg < config_.leg_count(); ++leg) {
    FootReading foot;
    foot.force_n = state_.legs[leg].foot_normal_force_n + gaussian(imperfections_.foot_noise_n);
    if (imperfections_.contact_dropout > 0.0 && std::uniform_real_distribution<double>(0, 1)(rng_) < imperfections_.contact_dropout) {
      foot.force_n = 0.0;
    }
    foot.sequence = sequence_;
    emit(encode_foot(config_.foot_frame_ids[leg], foot));
  }
  emit(encode_trunk_pose(config_.trunk_pose_frame_id, {state_.trunk.x_m, state_.trunk.pitch_rad, state_.trunk.height_m}));
  emit(encode_trunk_speed(config_.trunk_speed_frame_id, state_.trunk.vx_mps));
  for (int j = 0; j < joint_count(); ++j) {
    if (!twins_[j]->enabled()) continue;  // an idle ODrive still streams, but nobody needs it
    out_.clear();
    twins_[j]->cyclic(motor_state(j), out_);
    emit_all(out_, true);
  }
}

void RobotDevice::emit(const can::CanFrame& frame) {
  if (imperfections_.latency_s > 0.0) {
    delayed_.push_back({monotonic_ns() + std::llround(imperfections_.latency_s * 1e9), frame});
    return;
  }
  bus_.send(frame);
}

void RobotDevice::flush() {
  const std::int64_t now = monotonic_ns();
  while (!delayed_.empty() && delayed_.front().due_ns <= now) {
    bus_.send(delayed_.front().frame);
    delayed_.pop_front();
  }
}

}  // namespace cpgmatch::robot

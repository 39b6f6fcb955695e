#include "cpgmatch/robot/robot_device.hpp"

#include <algorithm>
#include <cmath>

#include "cpgmatch/robot/sensor_protocol.hpp"

namespace cpgmatch::robot {

RobotDevice::RobotDevice(const RobotConfig& config, can::CanBus& bus, DeviceImperfections imperfections)
    : config_(config), bus_(bus), imperfections_(imperfections), rng_(imperfections.seed) {
  for (std::size_t leg = 0; leg < kHardwareLegs; ++leg) {
    joints_[joint_index(leg, true)] = &config_.hips[leg];
    joints_[joint_index(leg, false)] = &config_.knees[leg];
    commands_[leg].hip_passive = true;  // motors start off
  }
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
  for (int j = 0; j < kNumJoints; ++j) {
    if (frame.id != joints_[j]->node_id) continue;
    const auto received = mit_decode_command(frame, config_.ranges);
    if (!received) return result;  // wrong length: a real driver ignores it
    result.joint = j;
    const int leg = j / 2;
    const bool hip = j % 2 == 0;
    const JointConfig& joint = *joints_[j];
    switch (received->kind) {
      case MitReceived::Kind::kEnterMotorMode:
        enabled_[j] = true;
        last_command_ns_[j] = monotonic_ns();  // the watchdog counts from entering motor mode
        result.event = Event::kEnable;
        break;
      case MitReceived::Kind::kExitMotorMode:
        enabled_[j] = false;
        if (hip) commands_[leg].hip_passive = true;
        result.event = Event::kDisable;
        break;
      case MitReceived::Kind::kSetZero:
        zero_[j] = joint.to_motor_position(position_[j]);
        result.event = Event::kZero;
        break;
      case MitReceived::Kind::kCommand: {
        result.event = Event::kCommand;
        if (!enabled_[j]) break;  // a motor out of motor mode ignores commands
        const MotorCommand& c = received->command;
        last_command_[j] = c;
        last_command_ns_[j] = monotonic_ns();
        timed_out_[j] = false;
        commanded_[j] = true;
        const double target = joint.to_joint_position(c.position_rad + zero_[j]);
        if (hip) {
          // The body model has its own motor law (the ODE hip PD); kp = kd = 0 is the passive hip, and
          // kp = 0 with damping (the safe state) is passive too: the model has no pure-damping mode.
          commands_[leg].hip_passive = c.kp_nm_per_rad <= 0.0;
          commands_[leg].hip_angle_rad = target;
        } else if (c.kp_nm_per_rad > 0.0) {
          commands_[leg].knee_flexion_rad = target;
        }
        break;
      }
    }
    return result;
  }
  return result;
}

int RobotDevice::enforce_command_timeout(std::int64_t now_ns, std::int64_t timeout_ns) {
  int made_safe = 0;
  for (int j = 0; j < kNumJoints; ++j) {
    if (!enabled_[j] || timed_out_[j] || now_ns - last_command_ns_[j] < timeout_ns) continue;
    MotorCommand safe;  // kp = 0, feed-forward 0: the motor only damps
    safe.position_rad = last_command_[j].position_rad;
    safe.kd_nm_s_per_rad = joints_[j]->to_motor_kd(config_.safety.safe_damping_nm_s_per_rad);
    last_command_[j] = safe;
    if (j % 2 == 0) commands_[j / 2].hip_passive = true;  // the body model's hip has no pure-damping mode
    timed_out_[j] = true;
    ++made_safe;
  }
  return made_safe;
}

bool RobotDevice::all_commanded() const {
  for (const bool c : commanded_) {
    if (!c) return false;
  }
  return true;
}

void RobotDevice::update(const PlantState& state, double dt_s) {
  for (std::size_t leg = 0; leg < kHardwareLegs; ++leg) {
    const std::array<double, 2> positions{state.legs[leg].hip_angle_rad, state.legs[leg].knee_flexion_rad};
    const std::array<double, 2> torques{state.legs[leg].hip_torque_nm, state.legs[leg].knee_torque_nm};
    for (int k = 0; k < 2; ++k) {
      const int j = leg * 2 + k;
      velocity_[j] = have_state_ && dt_s > 0.0 ? (positions[k] - position_[j]) / dt_s : 0.0;
      position_[j] = positions[k];
      const double play = 0.5 * imperfections_.backlash_rad;
      encoder_[j] = have_state_ ? std::clamp(encoder_[j], positions[k] - play, positions[k] + play) : positions[k];
      torque_[j] = torques[k];
    }
  }
  state_ = state;
  have_state_ = true;
}

void RobotDevice::reply(int j) {
  if (imperfections_.reply_dropout > 0.0 && std::uniform_real_distribution<double>(0, 1)(rng_) < imperfections_.reply_dropout) return;
  const JointConfig& joint = *joints_[j];
  MotorFeedback fb;
  fb.node_id = joint.node_id;
  fb.position_rad = joint.to_motor_position(encoder_[j] + gaussian(imperfections_.position_noise_rad)) - zero_[j];
  fb.velocity_rad_s = joint.to_motor_velocity(velocity_[j]);
  fb.torque_nm = joint.to_motor_torque(torque_[j]);
  emit(mit_encode_reply(config_.host_id, fb, config_.ranges));
}

void RobotDevice::reply_all() {
  for (int j = 0; j < kNumJoints; ++j) reply(j);
}

void RobotDevice::send_sensors() {
  ++sequence_;
  for (std::size_t leg = 0; leg < kHardwareLegs; ++leg) {
    FootReading foot;
    foot.force_n = state_.legs[leg].foot_normal_force_n + gaussian(imperfections_.foot_noise_n);
    if (imperfections_.contact_dropout > 0.0 && std::uniform_real_distribution<double>(0, 1)(rng_) < imperfections_.contact_dropout) {
      foot.force_n = 0.0;
    }
    foot.sequence = sequence_;
    emit(encode_foot(config_.foot_node_ids[leg], foot));
  }
  emit(encode_trunk_pose(config_.trunk_node_id, {state_.trunk.x_m, state_.trunk.pitch_rad, state_.trunk.height_m}));
  emit(encode_trunk_speed(config_.trunk_node_id, state_.trunk.vx_mps));
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

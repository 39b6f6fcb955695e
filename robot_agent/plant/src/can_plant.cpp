#include "cpgmatch/robot/can_plant.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <limits>
#include <vector>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot/sensor_protocol.hpp"

namespace cpgmatch::robot {
namespace {

constexpr std::uint32_t kCanErrBusOff = 0x40;  // CAN_ERR_BUSOFF (linux/can/error.h)

const char* joint_label(const JointConfig& j) { return j.name.c_str(); }

}  // namespace

CanPlant::CanPlant(const RobotConfig& config, can::CanBus& bus, CanPlantOptions options)
    : config_(config),
      bus_(bus),
      options_(options),
      period_s_(1.0 / config.control_rate_hz),
      period_ns_(std::llround(1e9 / config.control_rate_hz)),
      timeout_ns_(std::llround(config.safety.feedback_timeout_s * 1e9)),
      joint_count_(config.joint_count()),
      timer_(period_ns_) {
  if (auto why = config_.plant_mismatch()) throw InputError(*why);
  std::vector<can::CanFilter> filters;
  std::size_t max_frames = 0;
  for (const JointConfig& joint : config_.joints) {
    motors_.push_back(make_joint_protocol(joint));
    motors_.back()->feedback_filters(filters);
    max_frames += motors_.back()->max_frames();
    joint_timeout_ns_.push_back(std::llround(config_.feedback_timeout_s(joint) * 1e9));
    // The stall watch waits for the slowest joint's timeout.
    timeout_ns_ = std::max(timeout_ns_, joint_timeout_ns_.back());
  }
  for (int leg = 0; leg < config_.leg_count(); ++leg) {
    hip_of_leg_.push_back(config_.joint_index(leg, JointRole::kHip));
    knee_of_leg_.push_back(config_.joint_index(leg, JointRole::kKnee));
    filters.push_back({config_.foot_frame_ids[leg], can::kMaxStandardId, false});
  }
  filters.push_back({config_.trunk_pose_frame_id, can::kMaxStandardId, false});
  filters.push_back({config_.trunk_speed_frame_id, can::kMaxStandardId, false});
  loop_frames_.reserve(max_frames);
  safe_frames_.reserve(max_frames);
  const std::size_t n = static_cast<std::size_t>(joint_count_);
  sent_.assign(n, MotorCommand{});
  position_.assign(n, 0.0);
  velocity_.assign(n, 0.0);
  torque_.assign(n, 0.0);
  motor_heard_ns_.assign(n, 0);
  targets_ = PerLeg<JointCommand>(config_.legs.size());
  foot_force_.assign(config_.legs.size(), 0.0);
  foot_heard_ns_.assign(config_.legs.size(), 0);
  bus_.set_filters(filters);
  bus_.set_error_frames(true);
  if (options_.watchdog_thread) watch_thread_ = std::thread([this] { watch_loop(); });
}

CanPlant::~CanPlant() {
  stop_watch_ = true;
  if (watch_thread_.joinable()) watch_thread_.join();
}

void CanPlant::trip(const char* format, ...) {
  bool expected = false;
  // The first trip wins and writes the reason; later ones (the other thread, follow-up faults) only
  // re-send the safe state.
  const bool first = tripped_.compare_exchange_strong(expected, true, std::memory_order_acq_rel);
  if (first) {
    va_list args;
    va_start(args, format);
    std::vsnprintf(fault_.data(), fault_.size(), format, args);
    va_end(args);
    silent_since_at_trip_ns_.store(*std::min_element(motor_heard_ns_.begin(), motor_heard_ns_.end()),
                                   std::memory_order_release);
  }
  send_safe_state();
  if (first) safe_sent_ns_.store(monotonic_ns(), std::memory_order_release);
}

void CanPlant::emergency_stop(const char* reason) { trip("emergency stop: %s", reason); }

std::optional<std::string> CanPlant::fault() const {
  if (!tripped()) return std::nullopt;
  return std::string(fault_.data());
}

void CanPlant::send_safe_state() {
  // Any thread may trip (the loop, the watch thread, a signal or DDS thread's emergency stop): the safe
  // state has its own frames under a lock, taken only on this fault path.
  std::lock_guard<std::mutex> lock(safe_mutex_);
  safe_frames_.clear();
  for (int j = 0; j < joint_count_; ++j) {
    MotorCommand safe;  // kp = 0, feed-forward 0: the motor only damps
    safe.kd_nm_s_per_rad = config_.joints[j].to_motor_kd(config_.safe_damping(config_.joints[j]));
    motors_[j]->command(safe, safe_frames_);
  }
  try {
    bus_.send(safe_frames_.frames());
  } catch (const can::CanError&) {
    // A broken bus cannot carry the safe state; the drivers' own CAN timeout is the last line.
  }
}

PlantLifecycle CanPlant::lifecycle() const {
  if (tripped()) return PlantLifecycle::kFault;
  return active_.load(std::memory_order_acquire) ? PlantLifecycle::kActive : PlantLifecycle::kInactive;
}

std::optional<std::string> CanPlant::prepare(double rollout_s) {
  active_ = false;
  rollout_ticks_ = std::numeric_limits<std::uint64_t>::max();  // the stand-up ramp is not the rollout
  tripped_ = false;
  fault_seen_ = false;
  safe_sent_ns_ = 0;
  silent_since_at_trip_ns_ = 0;
  fault_.fill(0);
  heartbeat_ns_ = 0;
  std::fill(motor_heard_ns_.begin(), motor_heard_ns_.end(), 0);
  std::fill(foot_heard_ns_.begin(), foot_heard_ns_.end(), 0);
  trunk_heard_ns_ = 0;
  can::CanFrame stale;
  while (bus_.receive(stale, std::chrono::nanoseconds(0))) {
  }
  // Enable (closed loop, limp until the first command); each protocol's device then reports its state.
  // Retried, since a frame can be lost.
  const std::int64_t asked = monotonic_ns();
  const auto wait_ns = std::llround(options_.enable_timeout_s * 1e9);
  for (int attempt = 0; attempt < 3 && !everything_heard_since(asked); ++attempt) {
    loop_frames_.clear();
    for (auto& motor : motors_) motor->enable(loop_frames_);
    bus_.send(loop_frames_.frames());
    receive_until(monotonic_ns() + wait_ns / 3);
  }
  if (tripped()) return fault();
  for (int j = 0; j < joint_count_; ++j) {
    if (motor_heard_ns_[j] < asked) {
      const JointConfig& joint = config_.joints[j];
      trip("motor %s (%s node %u) does not answer", joint_label(joint), joint.protocol.c_str(), joint.node_id);
      return fault();
    }
  }
  for (int leg = 0; leg < config_.leg_count(); ++leg) {
    if (foot_heard_ns_[leg] < asked) {
      trip("%s foot sensor (frame id %u) is silent", config_.legs[leg].c_str(), config_.foot_frame_ids[leg]);
      return fault();
    }
  }
  if (trunk_heard_ns_ < asked) {
    trip("trunk sensor (frame id %u) is silent", config_.trunk_pose_frame_id);
    return fault();
  }
  // Answers to repeated enables may still be on their way; left in the queue they would be taken for
  // the first period's replies and every later period would read the one before. Drain until the bus
  // has been quiet for 5 ms (at most 50 ms: streaming sensors never go quiet, and need not).
  for (const std::int64_t give_up = monotonic_ns() + 50'000'000; monotonic_ns() < give_up;) {
    if (!bus_.receive(stale, std::chrono::milliseconds(5))) break;
    handle(stale, monotonic_ns());
  }

  // Ramp to the standing pose (all joint targets 0) at the configured speed, from where the joints are.
  double distance = 0.0;
  std::vector<double> start(static_cast<std::size_t>(joint_count_));
  for (int j = 0; j < joint_count_; ++j) {
    start[j] = position_[j];
    distance = std::max(distance, std::abs(start[j]));
  }
  timer_.start();
  expect_since_ns_ = 0;
  if (distance > config_.safety.stand_tolerance_rad) {
    const int steps = static_cast<int>(std::ceil(distance / config_.safety.stand_ramp_speed_rad_s / period_s_));
    for (int step = 1; step <= steps && !tripped(); ++step) {
      const double remaining = 1.0 - static_cast<double>(step) / steps;
      PerLeg<JointCommand> ramp(config_.legs.size());
      for (int leg = 0; leg < config_.leg_count(); ++leg) {
        ramp[leg].hip_angle_rad = start[hip_of_leg_[leg]] * remaining;
        ramp[leg].knee_flexion_rad = start[knee_of_leg_[leg]] * remaining;
      }
      command(ramp);
      advance(period_s_);
    }
    if (tripped()) return fault();
  }
  // The rollout's clock and statistics start now.
  time_s_ = 0.0;
  jitter_.reset();
  feedback_latency_.reset();
  ticks_ = 0;
  missing_replies_ = 0;
  unexpected_frames_ = 0;
  overruns_in_row_ = 0;
  rollout_ticks_ = static_cast<std::uint64_t>(std::llround(rollout_s / period_s_));
  expect_since_ns_ = 0;
  timer_.start();
  active_ = true;
  return std::nullopt;
}

void CanPlant::finish() {
  active_ = false;
  heartbeat_ns_ = 0;  // the loop stops ticking on purpose: the watch thread must not trip
  send_safe_state();
  std::lock_guard<std::mutex> lock(safe_mutex_);
  safe_frames_.clear();
  for (auto& motor : motors_) motor->disable(safe_frames_);
  try {
    bus_.send(safe_frames_.frames());
  } catch (const can::CanError&) {
  }
}

void CanPlant::command(const PerLeg<JointCommand>& commands) {
  for (int leg = 0; leg < config_.leg_count(); ++leg) {
    JointCommand c = commands[leg];
    const JointConfig& hip = config_.joints[hip_of_leg_[leg]];
    const JointConfig& knee = config_.joints[knee_of_leg_[leg]];
    auto bounded = [&](double target, const JointConfig& j, int index) {
      if (!std::isfinite(target)) target = position_[index];  // a NaN target holds the joint where it is
      target = std::clamp(target, j.position_min_rad, j.position_max_rad);
      // The driver's torque kp (target - p) - kd v (v_des = 0) must stay within the torque limit: the
      // target may lead the measured angle by at most (limit +- kd v) / kp. The damping term is part of
      // the bound, so a target far ahead gives exactly the saturated torque a torque-limited PD gives.
      if (j.kp_nm_per_rad > 0.0) {
        const double damping = j.kd_nm_s_per_rad * velocity_[index];
        const double low = position_[index] + (-j.torque_max_nm + damping) / j.kp_nm_per_rad;
        const double high = position_[index] + (j.torque_max_nm + damping) / j.kp_nm_per_rad;
        target = std::clamp(target, std::min(low, high), std::max(low, high));
      }
      return target;
    };
    c.hip_angle_rad = bounded(c.hip_angle_rad, hip, hip_of_leg_[leg]);
    c.knee_flexion_rad = bounded(c.knee_flexion_rad, knee, knee_of_leg_[leg]);
    targets_[leg] = c;
  }
}

void CanPlant::send_commands() {
  loop_frames_.clear();
  for (int j = 0; j < joint_count_; ++j) {
    const JointConfig& joint = config_.joints[j];
    const bool hip = joint.role == JointRole::kHip;
    const JointCommand& target = targets_[joint.leg];
    MotorCommand& m = sent_[j];
    m = MotorCommand{};
    if (!(hip && target.hip_passive)) {  // a passive hip (impact mitigation): kp = kd = 0, no torque
      m.position_rad = joint.to_motor_position(hip ? target.hip_angle_rad : target.knee_flexion_rad);
      m.kp_nm_per_rad = joint.to_motor_kp(joint.kp_nm_per_rad);
      m.kd_nm_s_per_rad = joint.to_motor_kd(joint.kd_nm_s_per_rad);
    }
    motors_[j]->command(m, loop_frames_);
  }
  bus_.send(loop_frames_.frames());
}

bool CanPlant::handle(const can::CanFrame& frame, std::int64_t now_ns) {
  if (frame.error) {
    if (frame.id & kCanErrBusOff) trip("CAN controller is bus-off");
    return true;
  }
  for (int j = 0; j < joint_count_; ++j) {
    const FeedbackResult r = motors_[j]->decode_feedback(frame);
    if (r.status == FeedbackStatus::kNotMine) continue;
    if (r.status != FeedbackStatus::kOk) break;  // this motor's id, but a corrupt frame
    const JointConfig& joint = config_.joints[j];
    if (r.fault != 0) {
      trip("motor %s (%s node %u) reports %s 0x%X", joint_label(joint), joint.protocol.c_str(), joint.node_id, r.fault_kind, r.fault);
      return true;
    }
    if (r.has_position) {
      position_[j] = joint.to_joint_position(r.feedback.position_rad);
      velocity_[j] = joint.to_joint_velocity(r.feedback.velocity_rad_s);
      motor_heard_ns_[j] = now_ns;
    }
    if (r.has_torque) torque_[j] = joint.to_joint_torque(r.feedback.torque_nm);
    return true;
  }
  for (int leg = 0; leg < config_.leg_count(); ++leg) {
    if (frame.id != config_.foot_frame_ids[leg] || frame.extended) continue;
    const auto reading = decode_foot(frame, frame.id);
    if (!reading) break;
    if (reading->fault) trip("%s foot sensor reports a fault", config_.legs[leg].c_str());
    foot_force_[leg] = reading->force_n;
    foot_heard_ns_[leg] = now_ns;
    return true;
  }
  if (const auto pose = decode_trunk_pose(frame, config_.trunk_pose_frame_id)) {
    trunk_.x_m = pose->x_m;
    trunk_.pitch_rad = pose->pitch_rad;
    trunk_.height_m = pose->height_m;
    trunk_heard_ns_ = now_ns;
    return true;
  }
  if (const auto speed = decode_trunk_speed(frame, config_.trunk_speed_frame_id)) {
    trunk_.vx_mps = *speed;
    return true;
  }
  ++unexpected_frames_;
  return false;
}

bool CanPlant::all_motors_heard_since(std::int64_t since_ns) const {
  for (const auto t : motor_heard_ns_) {
    if (t < since_ns) return false;
  }
  return true;
}

bool CanPlant::everything_heard_since(std::int64_t since_ns) const {
  if (!all_motors_heard_since(since_ns)) return false;
  for (const auto t : foot_heard_ns_) {
    if (t < since_ns) return false;
  }
  return trunk_heard_ns_ >= since_ns;
}

void CanPlant::receive_until(std::int64_t deadline_ns) {
  const std::int64_t sent_at = monotonic_ns();
  bool motors_answered = false;
  can::CanFrame frame;
  while (true) {
    const std::int64_t now = monotonic_ns();
    if (!motors_answered && all_motors_heard_since(sent_at)) {
      feedback_latency_.record(now - sent_at);  // command to the last motor's reply
      motors_answered = true;
    }
    if (now >= deadline_ns) return;
    // Every motor answered this period's command and every sensor spoke: nothing more to wait for.
    if (motors_answered && everything_heard_since(sent_at)) return;
    if (!bus_.receive(frame, std::chrono::nanoseconds(deadline_ns - now))) continue;
    handle(frame, monotonic_ns());
  }
}

void CanPlant::check_watchdog(std::int64_t now_ns) {
  auto silence = [&](std::int64_t heard_ns) { return now_ns - std::max(heard_ns, expect_since_ns_); };
  for (int j = 0; j < joint_count_; ++j) {
    const JointConfig& joint = config_.joints[j];
    if (silence(motor_heard_ns_[j]) > joint_timeout_ns_[j]) {
      trip("motor %s (%s node %u) silent for %.1f ms", joint_label(joint), joint.protocol.c_str(), joint.node_id,
           silence(motor_heard_ns_[j]) * 1e-6);
      return;
    }
    if (std::abs(velocity_[j]) > joint.velocity_max_rad_s) {
      trip("%s moves at %.2f rad/s, over its limit %.2f", joint_label(joint), velocity_[j], joint.velocity_max_rad_s);
      return;
    }
    // The driver's own loop may briefly exceed the commanded bound on impacts; 1.5x is a real fault.
    if (std::abs(torque_[j]) > 1.5 * joint.torque_max_nm) {
      trip("%s torque %.2f N m, over 1.5 x its limit %.2f", joint_label(joint), torque_[j], joint.torque_max_nm);
      return;
    }
  }
  const std::int64_t sensor_timeout_ns = std::llround(config_.safety.feedback_timeout_s * 1e9);
  for (int leg = 0; leg < config_.leg_count(); ++leg) {
    if (silence(foot_heard_ns_[leg]) > sensor_timeout_ns) {
      trip("%s foot sensor silent for %.1f ms", config_.legs[leg].c_str(), silence(foot_heard_ns_[leg]) * 1e-6);
      return;
    }
  }
  if (silence(trunk_heard_ns_) > sensor_timeout_ns) {
    trip("trunk sensor silent for %.1f ms", silence(trunk_heard_ns_) * 1e-6);
  }
}

void CanPlant::advance(double /*dt_s: always the control period; the rollout asks for time_step_s()*/) {
  if (tripped()) {
    send_safe_state();
    return;
  }
  const std::int64_t tick_start = monotonic_ns();
  if (expect_since_ns_ == 0) expect_since_ns_ = tick_start;
  for (int j = 0; j < joint_count_; ++j) {
    if (tick_start - motor_heard_ns_[j] > period_ns_ + period_ns_ / 2) ++missing_replies_;
  }
  bool overran = false;
  try {
    send_commands();
    // An overrun: the period's work (the controller and cost between ticks, sending) already ran past
    // the deadline. Waiting for replies up to the deadline is not work.
    overran = monotonic_ns() > to_ns(timer_.deadline());
    std::int64_t wait_until = to_ns(timer_.deadline());
    if (options_.wait_for_every_reply) wait_until = std::max(wait_until, monotonic_ns() + timeout_ns_);
    receive_until(wait_until);
  } catch (const can::CanError& e) {
    trip("CAN bus failed: %s", e.what());
    return;
  }
  bool deadline_passed = false;
  const std::int64_t lateness = timer_.wait(deadline_passed);
  jitter_.record(lateness);
  if (overran) {
    jitter_.add_overrun();
    if (++overruns_in_row_ >= config_.safety.max_consecutive_overruns) {
      trip("control loop missed %d deadlines in a row", overruns_in_row_);
    }
  } else {
    overruns_in_row_ = 0;
  }
  const std::int64_t now = monotonic_ns();
  check_watchdog(now);
  ++ticks_;
  time_s_ += period_s_;
  if (ticks_ >= rollout_ticks_) {
    heartbeat_ns_.store(0, std::memory_order_release);  // over on purpose: nothing to watch
    send_safe_state();
    return;
  }
  heartbeat_ns_.store(now, std::memory_order_release);
}

PlantState CanPlant::state() const {
  PlantState s;
  s.time_s = time_s_;
  s.trunk = trunk_;
  if (tripped()) {
    // Not a measurement any more: the rollout must stop (run_rollout ends on a non-finite state).
    s.trunk.pitch_rad = std::numeric_limits<double>::quiet_NaN();
    fault_seen_.store(true, std::memory_order_release);
  }
  s.legs = PerLeg<LegState>(config_.legs.size());
  for (int leg = 0; leg < config_.leg_count(); ++leg) {
    LegState& l = s.legs[leg];
    const int hip = hip_of_leg_[leg], knee = knee_of_leg_[leg];
    l.hip_angle_rad = position_[hip];
    l.knee_flexion_rad = position_[knee];
    l.hip_torque_nm = torque_[hip];
    l.knee_torque_nm = torque_[knee];
    l.foot_normal_force_n = foot_force_[leg];
    // The motors' own encoders: the knee motor's is its output, the spring's rest side (energy.hpp needs it).
    l.hip_speed_rad_s = velocity_[hip];
    l.knee_motor_speed_rad_s = velocity_[knee];
  }
  return s;
}

LoopStats CanPlant::loop_stats() const {
  LoopStats s;
  s.ticks = ticks_;
  s.jitter_p50_us = jitter_.percentile_us(0.50);
  s.jitter_p99_us = jitter_.percentile_us(0.99);
  s.jitter_max_us = jitter_.max_us();
  s.overruns = jitter_.overruns();
  s.feedback_latency_p50_us = feedback_latency_.percentile_us(0.50);
  s.feedback_latency_p99_us = feedback_latency_.percentile_us(0.99);
  s.feedback_latency_max_us = feedback_latency_.max_us();
  s.missing_replies = missing_replies_;
  s.unexpected_frames = unexpected_frames_;
  return s;
}

void CanPlant::watch_loop() {
  // Independent of the control loop: if it stops ticking (stuck in a call, starved of CPU) while a
  // rollout runs, the motors still go safe within the feedback timeout plus one period.
  const std::int64_t stall_ns = timeout_ns_ + period_ns_;
  std::int64_t last_resend = 0;
  while (!stop_watch_.load()) {
    struct timespec nap {0, 2'000'000};
    nanosleep(&nap, nullptr);
    const std::int64_t beat = heartbeat_ns_.load(std::memory_order_acquire);
    if (beat == 0) continue;
    const std::int64_t now = monotonic_ns();
    if (now - beat <= stall_ns) continue;
    if (!tripped()) {
      trip("control loop stalled for %.1f ms", (now - beat) * 1e-6);
      last_resend = now;
    } else if (now - last_resend > 10'000'000) {
      send_safe_state();  // keep the drivers in the safe state while nobody else talks to them
      last_resend = now;
    }
  }
}

}  // namespace cpgmatch::robot

// CanPlant against a scripted robot on a virtual bus (RobotDevice around a body whose joints follow
// their targets exactly): the protocol, the limits, the watchdog, the safe state, a common/ rollout.
#include <algorithm>
#include <atomic>
#include <vector>
#include <thread>

#include <gtest/gtest.h>

#include "cpgmatch/errors.hpp"

#include "cpgmatch/can/can_bus.hpp"
#include "cpgmatch/robot/can_plant.hpp"
#include "cpgmatch/robot/realtime.hpp"
#include "cpgmatch/robot/robot_device.hpp"
#include "cpgmatch/robot/sensor_protocol.hpp"
#include "cpgmatch/rollout.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch::robot {
namespace {

// Morti's description lists each leg's hip then knee (configs/robot/morti.yaml): joint 2 leg + 0 / 1.
constexpr int kNumJoints = 2 * kNumLegs;
int joint_index(int leg, bool hip) { return leg * 2 + (hip ? 0 : 1); }


using namespace std::chrono_literals;

// A robot whose joints sit exactly at their targets, feet loaded with 10 N, trunk level at 0.25 m. It
// answers every command at once and streams its sensors every 2 ms, until told to fall silent.
class ScriptedRobot {
 public:
  ScriptedRobot(const RobotConfig& config, const std::string& bus_uri, int mute_joint = -1)
      : bus_(can::open_can_bus(bus_uri, can::BusRole::kDevice)), device_(config, *bus_), mute_joint_(mute_joint) {
    thread_ = std::thread([this] { run(); });
  }
  ~ScriptedRobot() {
    stop_ = true;
    thread_.join();
  }
  void go_silent() {
    silent_since_ns_ = monotonic_ns();
    silent_ = true;
  }
  std::int64_t silent_since_ns() const { return silent_since_ns_; }
  std::int64_t last_reply_ns() const { return last_reply_ns_; }
  // The first time after `since_ns` that every motor was told the safe state (kp = 0, kd > 0); 0 if not yet.
  std::int64_t all_safe_at() const { return all_safe_ns_; }
  MotorCommand last_command(int joint) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return device_.last_command(joint);
  }

 private:
  void run() {
    std::int64_t next_sensors = 0;
    while (!stop_) {
      std::unique_lock<std::mutex> lock(mutex_);
      const auto got = device_.receive(200us);
      PlantState s;
      s.legs = PerLeg<LegState>(4);
      s.trunk.height_m = 0.25;
      s.trunk.x_m = 0.01;
      for (int leg = 0; leg < kNumLegs; ++leg) {
        const JointCommand& c = device_.joint_commands()[leg];
        s.legs[leg].hip_angle_rad = c.hip_angle_rad;
        s.legs[leg].knee_flexion_rad = c.knee_flexion_rad;
        s.legs[leg].hip_torque_nm = 0.5;
        s.legs[leg].foot_normal_force_n = 10.0;
      }
      device_.update(s, 0.0);
      if (silent_) {
        bool all_safe = true;
        for (int j = 0; j < kNumJoints; ++j) {
          const MotorCommand& c = device_.last_command(j);
          all_safe = all_safe && device_.last_command_ns(j) > silent_since_ns_ && c.kp_nm_per_rad == 0.0 && c.kd_nm_s_per_rad > 0.0;
        }
        if (all_safe && all_safe_ns_ == 0) all_safe_ns_ = monotonic_ns();
        continue;
      }
      if (got.reply_owed && got.joint != mute_joint_) {
        device_.reply(got.joint);
        last_reply_ns_ = monotonic_ns();
      }
      if (monotonic_ns() >= next_sensors) {
        device_.send_sensors();
        next_sensors = monotonic_ns() + 2'000'000;
      }
    }
  }

  std::unique_ptr<can::CanBus> bus_;
  RobotDevice device_;
  int mute_joint_;
  mutable std::mutex mutex_;
  std::atomic<bool> stop_{false}, silent_{false};
  std::atomic<std::int64_t> silent_since_ns_{0}, last_reply_ns_{0}, all_safe_ns_{0};
  std::thread thread_;
};

RobotConfig morti() { return load_robot_config(default_robot_config_path()); }

// Tests of the protocol path, not of the safety timing, must not fail because this shared machine
// descheduled the loop for a few milliseconds: no stall watch, generous overrun and silence limits.
RobotConfig tolerant_morti() {
  RobotConfig c = morti();
  c.safety.max_consecutive_overruns = 100;
  c.safety.feedback_timeout_s = 0.5;  // beyond what the YAML allows: this machine is shared
  return c;
}
const CanPlantOptions kNoStallWatch{0.2, false};

PerLeg<JointCommand> pose(double hip, double knee) {
  PerLeg<JointCommand> c(test::kNumLegs);
  for (auto& leg : c) {
    leg.hip_angle_rad = hip;
    leg.knee_flexion_rad = knee;
  }
  return c;
}

TEST(CanPlant, PreparesAndFollowsCommands) {
  const RobotConfig config = tolerant_morti();
  ScriptedRobot robot(config, "virtual:plant-follow");
  auto bus = can::open_can_bus("virtual:plant-follow");
  CanPlant plant(config, *bus, kNoStallWatch);
  ASSERT_EQ(plant.prepare(10.0), std::nullopt);
  for (int i = 0; i < 50; ++i) {
    plant.command(pose(0.05, 0.1));
    plant.advance(plant.time_step_s());
  }
  EXPECT_FALSE(plant.tripped()) << plant.fault().value_or("");
  const PlantState s = plant.state();
  EXPECT_NEAR(s.time_s, 0.1, 1e-9);
  EXPECT_NEAR(s.legs[kFrontRight].hip_angle_rad, 0.05, 1e-3);  // through a direction -1 motor and back
  EXPECT_NEAR(s.legs[kHindLeft].knee_flexion_rad, 0.1, 1e-3);
  EXPECT_NEAR(s.legs[kFrontLeft].foot_normal_force_n, 10.0, 0.01);
  EXPECT_NEAR(s.trunk.height_m, 0.25, 1e-4);
  EXPECT_NEAR(s.legs[kFrontLeft].hip_torque_nm, 0.5, 0.01);
  // The hip's direction -1 shows at the motor.
  EXPECT_NEAR(plant.last_sent(joint_index(kFrontRight, true)).position_rad, -0.05, 1e-9);
  EXPECT_DOUBLE_EQ(plant.last_sent(joint_index(kFrontLeft, true)).kp_nm_per_rad, 40.0);
  const LoopStats stats = plant.loop_stats();
  EXPECT_EQ(stats.ticks, 50u);
  EXPECT_EQ(stats.unexpected_frames, 0u);
  plant.finish();
}

TEST(CanPlant, TargetsAreLimitedByPositionAndTorque) {
  const RobotConfig config = tolerant_morti();
  ScriptedRobot robot(config, "virtual:plant-limits");
  auto bus = can::open_can_bus("virtual:plant-limits");
  CanPlant plant(config, *bus, kNoStallWatch);
  ASSERT_EQ(plant.prepare(10.0), std::nullopt);
  // From 0, kp 40 and a 4 N m limit: the hip target may lead the measured angle by 0.1 rad at most.
  plant.command(pose(5.0, -5.0));
  plant.advance(plant.time_step_s());
  EXPECT_NEAR(plant.last_sent(joint_index(kFrontLeft, true)).position_rad, 0.1, 1e-3);
  EXPECT_NEAR(plant.last_sent(joint_index(kFrontLeft, false)).position_rad, -0.2, 1e-3);  // 4 / 20
  // Following the target step by step, it ends at the position limit, never beyond.
  for (int i = 0; i < 40; ++i) {
    plant.command(pose(5.0, -5.0));
    plant.advance(plant.time_step_s());
  }
  EXPECT_NEAR(plant.state().legs[kFrontLeft].hip_angle_rad, 1.4, 1e-3);
  EXPECT_NEAR(plant.state().legs[kFrontLeft].knee_flexion_rad, -0.7, 1e-3);
  // A NaN target holds the joint where it is.
  PerLeg<JointCommand> nan_pose = pose(std::nan(""), std::nan(""));
  plant.command(nan_pose);
  plant.advance(plant.time_step_s());
  EXPECT_NEAR(plant.last_sent(joint_index(kFrontLeft, true)).position_rad, 1.4, 1e-3);
  EXPECT_FALSE(plant.tripped()) << plant.fault().value_or("");
}

TEST(CanPlant, PassiveHipSendsZeroGains) {
  const RobotConfig config = tolerant_morti();
  ScriptedRobot robot(config, "virtual:plant-passive");
  auto bus = can::open_can_bus("virtual:plant-passive");
  CanPlant plant(config, *bus, kNoStallWatch);
  ASSERT_EQ(plant.prepare(10.0), std::nullopt);
  PerLeg<JointCommand> c = pose(0.1, 0.1);
  c[kHindLeft].hip_passive = true;
  plant.command(c);
  plant.advance(plant.time_step_s());
  const MotorCommand& m = plant.last_sent(joint_index(kHindLeft, true));
  EXPECT_EQ(m.kp_nm_per_rad, 0.0);
  EXPECT_EQ(m.kd_nm_s_per_rad, 0.0);
  EXPECT_EQ(m.torque_nm, 0.0);
  EXPECT_GT(plant.last_sent(joint_index(kHindLeft, false)).kp_nm_per_rad, 0.0);
}

// The reaction time is measured where the agent acts: from the last reply of the motor that fell silent
// first, as the plant received it, to the safe state leaving it. This shared machine has no real-time guarantee and sometimes deschedules a
// process for tens of milliseconds, so each timing test gets three attempts and passes when one meets
// 20 ms; a watchdog slower than 20 ms by design (a longer timeout, a missed check) fails all three.
double silence_to_safe_ms(const std::string& bus_name) {
  const RobotConfig config = morti();
  ScriptedRobot robot(config, bus_name);
  auto bus = can::open_can_bus(bus_name);
  CanPlant plant(config, *bus);
  EXPECT_EQ(plant.prepare(10.0), std::nullopt);
  for (int i = 0; i < 25; ++i) {
    plant.command(pose(0.05, 0.05));
    plant.advance(plant.time_step_s());
  }
  robot.go_silent();
  for (int i = 0; i < 50 && !plant.tripped(); ++i) {
    plant.command(pose(0.05, 0.05));
    plant.advance(plant.time_step_s());
  }
  EXPECT_TRUE(plant.tripped());
  if (!plant.tripped()) return 1e9;
  // The safe state reaches every motor, and the rollout sees a non-finite state and ends.
  for (int i = 0; i < 200 && robot.all_safe_at() == 0; ++i) std::this_thread::sleep_for(1ms);
  EXPECT_GT(robot.all_safe_at(), 0) << "the motors never received the safe state";
  EXPECT_NEAR(robot.last_command(0).kd_nm_s_per_rad, 0.5, 5.0 / 4095);
  EXPECT_FALSE(std::isfinite(plant.state().trunk.pitch_rad));
  EXPECT_TRUE(plant.fault_ended_rollout());
  // The loop itself may have been descheduled first on this machine ("control loop stalled"): then this
  // attempt did not time the silence watchdog.
  if (plant.fault()->find("silent for") == std::string::npos) return 1e9;
  return (plant.safe_state_sent_ns() - plant.silent_since_ns()) * 1e-6;
}

TEST(CanPlant, WatchdogMakesEveryMotorSafeWithin20msOfSilence) {
  std::vector<double> attempts;
  for (int attempt = 0; attempt < 3; ++attempt) {
    attempts.push_back(silence_to_safe_ms("virtual:plant-silence-" + std::to_string(attempt)));
    if (attempts.back() <= 20.0) break;
  }
  const double best = *std::min_element(attempts.begin(), attempts.end());
  RecordProperty("silence_to_safe_ms", std::to_string(best));
  EXPECT_LE(best, 20.0) << "last motor reply to the safe state, ms, in " << attempts.size() << " attempts";
}

double stall_to_safe_ms(const std::string& bus_name) {
  const RobotConfig config = morti();
  ScriptedRobot robot(config, bus_name);
  auto bus = can::open_can_bus(bus_name);
  CanPlant plant(config, *bus);
  EXPECT_EQ(plant.prepare(10.0), std::nullopt);
  for (int i = 0; i < 10; ++i) {
    plant.command(pose(0.0, 0.0));
    plant.advance(plant.time_step_s());
  }
  const std::int64_t last_tick = monotonic_ns();  // the plant stops ticking here
  for (int i = 0; i < 200 && !plant.tripped(); ++i) std::this_thread::sleep_for(1ms);
  EXPECT_TRUE(plant.tripped());
  if (!plant.tripped()) return 1e9;
  // A robot thread descheduled during the ticks above trips the silence watchdog first: not timed.
  if (plant.fault()->find("control loop stalled") == std::string::npos) return 1e9;
  return (plant.safe_state_sent_ns() - last_tick) * 1e-6;
}

TEST(CanPlant, AStalledLoopIsMadeSafeByTheWatchThread) {
  std::vector<double> attempts;
  for (int attempt = 0; attempt < 3; ++attempt) {
    attempts.push_back(stall_to_safe_ms("virtual:plant-stall-" + std::to_string(attempt)));
    if (attempts.back() <= 20.0) break;
  }
  EXPECT_LE(*std::min_element(attempts.begin(), attempts.end()), 20.0) << "last tick to the safe state, ms";
}

TEST(CanPlant, AMotorThatNeverAnswersStopsThePreparation) {
  const RobotConfig config = morti();
  ScriptedRobot robot(config, "virtual:plant-mute", joint_index(kHindRight, false));
  auto bus = can::open_can_bus("virtual:plant-mute");
  CanPlant plant(config, *bus);
  const auto why = plant.prepare(10.0);
  ASSERT_TRUE(why.has_value());
  EXPECT_EQ(*why, "motor HR_knee (mit node 8) does not answer");
}

TEST(CanPlant, EmergencyStopIsImmediate) {
  const RobotConfig config = morti();
  ScriptedRobot robot(config, "virtual:plant-estop");
  auto bus = can::open_can_bus("virtual:plant-estop");
  CanPlant plant(config, *bus);
  ASSERT_EQ(plant.prepare(10.0), std::nullopt);
  plant.emergency_stop("SIGTERM");
  EXPECT_TRUE(plant.tripped());
  EXPECT_EQ(*plant.fault(), "emergency stop: SIGTERM");
  for (int i = 0; i < 100 && robot.last_command(3).kd_nm_s_per_rad == 0.0; ++i) std::this_thread::sleep_for(1ms);
  EXPECT_EQ(robot.last_command(3).kp_nm_per_rad, 0.0);
  EXPECT_NEAR(robot.last_command(3).kd_nm_s_per_rad, 0.5, 5.0 / 4095);
}

TEST(CanPlant, RunsACommonRolloutAndEndsInTheSafeState) {
  const RobotConfig config = tolerant_morti();
  ScriptedRobot robot(config, "virtual:plant-rollout");
  auto bus = can::open_can_bus("virtual:plant-rollout");
  CanPlant plant(config, *bus, kNoStallWatch);
  RolloutSettings settings;
  settings.entrain_s = 0.2;
  settings.eval_s = 0.3;
  ASSERT_EQ(plant.prepare(settings.entrain_s + settings.eval_s), std::nullopt);
  const RolloutResult result = run_rollout(plant, CpgParameters{}, settings, 1);
  EXPECT_FALSE(plant.fault_ended_rollout()) << plant.fault().value_or("");
  EXPECT_FALSE(result.fell);
  EXPECT_NEAR(result.sim_time_s, 0.5, 1e-9);
  EXPECT_EQ(plant.loop_stats().ticks, 250u);
  for (int i = 0; i < 100 && robot.last_command(0).kd_nm_s_per_rad == 0.0; ++i) std::this_thread::sleep_for(1ms);
  EXPECT_EQ(robot.last_command(0).kp_nm_per_rad, 0.0) << "after the last period the motors only damp";
  plant.finish();
}

// The Plant lifecycle, as ros2_control's hardware components have it: inactive until activated, active
// while it may be driven, in fault once tripped, inactive again after deactivate(); a rollout runs only on
// an active plant.
TEST(CanPlant, ItsLifecycleGoesInactiveActiveFaultAndARolloutNeedsItActive) {
  const RobotConfig config = tolerant_morti();
  ScriptedRobot robot(config, "virtual:plant-lifecycle");
  auto bus = can::open_can_bus("virtual:plant-lifecycle");
  CanPlant plant(config, *bus, kNoStallWatch);
  Plant& body = plant;  // what a controller sees
  RolloutSettings settings;
  settings.entrain_s = 0.1;
  settings.eval_s = 0.1;
  EXPECT_EQ(body.lifecycle(), PlantLifecycle::kInactive);
  EXPECT_THROW((void)run_rollout(body, CpgParameters{}, settings, 1), InputError);
  ASSERT_EQ(body.activate(settings.entrain_s + settings.eval_s), std::nullopt);
  EXPECT_EQ(body.lifecycle(), PlantLifecycle::kActive);
  const RolloutResult r = run_rollout(body, CpgParameters{}, settings, 1);
  EXPECT_EQ(r.outcome, RolloutOutcome::kCompleted);
  body.deactivate();
  EXPECT_EQ(body.lifecycle(), PlantLifecycle::kInactive);
  EXPECT_THROW((void)run_rollout(body, CpgParameters{}, settings, 1), InputError);
  ASSERT_EQ(body.activate(1.0), std::nullopt);
  plant.emergency_stop("test");
  EXPECT_EQ(body.lifecycle(), PlantLifecycle::kFault);
  EXPECT_EQ(body.fault().value_or(""), "emergency stop: test");
  body.deactivate();
  ASSERT_EQ(body.activate(1.0), std::nullopt);  // a new activation clears the trip
  EXPECT_EQ(body.lifecycle(), PlantLifecycle::kActive);
  body.deactivate();
}

// A watchdog trip mid-rollout is the robot's fault, not the gait's: the rollout ends as a plant fault with
// the watchdog's reason, never as a fall the optimizer would learn from.
TEST(CanPlant, AWatchdogTripMidRolloutEndsItAsAPlantFaultNotAFall) {
  const RobotConfig config = tolerant_morti();
  ScriptedRobot robot(config, "virtual:plant-trip-rollout");
  auto bus = can::open_can_bus("virtual:plant-trip-rollout");
  CanPlant plant(config, *bus, kNoStallWatch);
  RolloutSettings settings;
  settings.entrain_s = 1.0;
  settings.eval_s = 1.0;
  ASSERT_EQ(plant.prepare(settings.entrain_s + settings.eval_s), std::nullopt);
  std::thread silence([&robot] {
    std::this_thread::sleep_for(300ms);
    robot.go_silent();  // every motor and sensor stops answering while the rollout runs
  });
  const RolloutResult result = run_rollout(plant, CpgParameters{}, settings, 1);
  silence.join();
  EXPECT_TRUE(plant.fault_ended_rollout());
  EXPECT_EQ(result.outcome, RolloutOutcome::kPlantFault) << to_string(result.outcome);
  EXPECT_NE(result.outcome_message.find(plant.fault().value_or("?")), std::string::npos) << result.outcome_message;
  EXPECT_LT(result.sim_time_s, 1.9);  // it ended early, at the trip
  plant.finish();
}

TEST(CanPlant, TheWatchThreadDoesNotCallTheRolloutsEndAStall) {
  const RobotConfig config = tolerant_morti();
  ScriptedRobot robot(config, "virtual:plant-end");
  auto bus = can::open_can_bus("virtual:plant-end");
  CanPlant plant(config, *bus);
  ASSERT_EQ(plant.prepare(0.02), std::nullopt);
  for (int i = 0; i < 10; ++i) {
    plant.command(pose(0.0, 0.0));
    plant.advance(plant.time_step_s());
  }
  std::this_thread::sleep_for(40ms);
  EXPECT_FALSE(plant.tripped()) << plant.fault().value_or("");
}

TEST(CanPlant, ForeignAndMalformedFramesAreCountedNotUsed) {
  const RobotConfig config = tolerant_morti();
  ScriptedRobot robot(config, "virtual:plant-foreign");
  auto bus = can::open_can_bus("virtual:plant-foreign");
  auto intruder = can::open_can_bus("virtual:plant-foreign");
  CanPlant plant(config, *bus, kNoStallWatch);
  ASSERT_EQ(plant.prepare(10.0), std::nullopt);
  plant.command(pose(0.0, 0.0));
  plant.advance(plant.time_step_s());
  // A 5-byte "reply" on the host id, a reply from a node no joint has, a foot frame of the wrong length.
  can::CanFrame short_reply = mit_encode_reply(config.host_id, {1, 3.0, 0.0, 0.0}, config.ranges);
  short_reply.length = 5;
  intruder->send(short_reply);
  intruder->send(mit_encode_reply(config.host_id, {42, 3.0, 0.0, 0.0}, config.ranges));
  can::CanFrame bad_foot = encode_foot(config.foot_frame_ids[0], {99.0, 0, false});
  bad_foot.length = 2;
  intruder->send(bad_foot);
  for (int i = 0; i < 5; ++i) {
    plant.command(pose(0.0, 0.0));
    plant.advance(plant.time_step_s());
  }
  EXPECT_FALSE(plant.tripped()) << plant.fault().value_or("");
  EXPECT_EQ(plant.loop_stats().unexpected_frames, 3u);
  EXPECT_NEAR(plant.state().legs[kFrontLeft].hip_angle_rad, 0.0, 1e-3) << "the bad frames moved nothing";
  EXPECT_NEAR(plant.state().legs[kFrontLeft].foot_normal_force_n, 10.0, 0.01);
}

TEST(CanPlant, BusOffErrorFrameTrips) {
  const RobotConfig config = tolerant_morti();
  ScriptedRobot robot(config, "virtual:plant-busoff");
  auto bus = can::open_can_bus("virtual:plant-busoff");
  auto controller = can::open_can_bus("virtual:plant-busoff");
  CanPlant plant(config, *bus, kNoStallWatch);
  ASSERT_EQ(plant.prepare(10.0), std::nullopt);
  can::CanFrame bus_off;
  bus_off.error = true;
  bus_off.id = 0x40;  // CAN_ERR_BUSOFF
  bus_off.length = 8;
  controller->send(bus_off);
  // The frame reaches the plant's receive thread asynchronously: under a loaded ctest it was once read only
  // after the first period (1 failure in 593 tests). What is tested is that bus-off trips the plant at all;
  // how fast a silent bus trips it is the watchdog's tests.
  for (int period = 0; period < 250 && !plant.tripped(); ++period) {
    plant.command(pose(0.0, 0.0));
    plant.advance(plant.time_step_s());
  }
  ASSERT_TRUE(plant.tripped());
  EXPECT_EQ(*plant.fault(), "CAN controller is bus-off");
}

TEST(JitterStats, PercentilesAndMax) {
  JitterStats j;
  for (int i = 0; i < 98; ++i) j.record(10'000);  // 10 us
  j.record(150'000);
  j.record(2'000'000);
  EXPECT_DOUBLE_EQ(j.percentile_us(0.5), 10.0);
  EXPECT_DOUBLE_EQ(j.percentile_us(0.99), 150.0);
  EXPECT_DOUBLE_EQ(j.max_us(), 2000.0);
  j.reset();
  EXPECT_EQ(j.samples(), 0u);
}

TEST(PeriodicTimer, SleepsToAbsoluteDeadlines) {
  PeriodicTimer timer(2'000'000);
  timer.start();
  const std::int64_t start = monotonic_ns();
  bool overran = false;
  for (int i = 0; i < 25; ++i) timer.wait(overran);
  const double elapsed_ms = (monotonic_ns() - start) * 1e-6;
  EXPECT_GE(elapsed_ms, 49.0);
  EXPECT_LT(elapsed_ms, 80.0);
}

}  // namespace
}  // namespace cpgmatch::robot

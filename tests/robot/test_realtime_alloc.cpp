// The real-time loop allocates nothing once the plant is active: a rollout's control loop (controller,
// feedback, contact sensing, cost recording, and the CAN plant's command and receive path) runs on the
// robot's SCHED_FIFO thread, where a call into the heap can take a lock or page in memory and miss a 2-ms
// deadline. Checked with a counting global allocator around every step of a real rollout on the CAN
// plant, over the udp bus backend (like socketcan, it neither allocates nor locks; the in-process virtual
// bus of the unit tests does both), with a robot answering on the device side.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <thread>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include "cpgmatch/can/can_bus.hpp"
#include "cpgmatch/domain/rollout_trace.hpp"
#include "cpgmatch/robot/can_plant.hpp"
#include "cpgmatch/robot/robot_config.hpp"
#include "cpgmatch/robot/robot_device.hpp"
#include "cpgmatch/rollout.hpp"

namespace {

// Counts allocations made by the thread that set `counting` (the rollout's), nowhere else.
std::atomic<long> g_allocations{0};
thread_local bool t_counting = false;

}  // namespace

void* operator new(std::size_t size) {
  if (t_counting) g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace cpgmatch::robot {
namespace {

// Wraps the plant the rollout drives: allocations are counted from the first command (the loop has begun,
// the plant is active) to the last step; what run_rollout does before and after its loop is not counted.
class AllocationWatch final : public Plant {
 public:
  explicit AllocationWatch(Plant& inner) : inner_(inner) {}
  void command(const PerLeg<JointCommand>& c) override {
    if (!started_) {
      started_ = true;
      t_counting = true;
      at_start_ = g_allocations.load();
    }
    inner_.command(c);
  }
  void advance(double dt_s) override {
    inner_.advance(dt_s);
    if (started_) in_loop_ = g_allocations.load() - at_start_;  // up to and including this step
  }
  PlantState state() const override { return inner_.state(); }
  double time_step_s() const override { return inner_.time_step_s(); }
  std::optional<std::string> fault() const override { return inner_.fault(); }
  long allocations_in_loop() const { return in_loop_; }
  void stop() { t_counting = false; }

 private:
  Plant& inner_;
  bool started_ = false;
  long at_start_ = 0;
  long in_loop_ = 0;
};

// Answers every command and sends sensor readings, as Morti's motor drivers and sensor boards do.
class AnsweringRobot {
 public:
  AnsweringRobot(const RobotConfig& config, const std::string& bus_name)
      : bus_(can::open_can_bus(bus_name, can::BusRole::kDevice)), device_(config, *bus_), thread_([this] { run(); }) {}
  ~AnsweringRobot() {
    stop_ = true;
    thread_.join();
  }

 private:
  void run() {
    std::int64_t next_sensors = 0;
    while (!stop_) {
      const RobotDevice::Received got = device_.receive(std::chrono::microseconds(200));
      PlantState s;
      s.legs = PerLeg<LegState>(4);
      s.trunk.height_m = 0.28;
      for (auto& leg : s.legs) leg.foot_normal_force_n = 10.0;
      device_.update(s, 0.0);
      if (got.reply_owed) device_.reply(got.joint);
      const auto now = std::chrono::steady_clock::now().time_since_epoch().count();
      if (now >= next_sensors) {
        device_.send_sensors();
        next_sensors = now + 2'000'000;
      }
    }
  }
  std::unique_ptr<can::CanBus> bus_;
  RobotDevice device_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// A UDP port on loopback that was free a moment ago (the robot side binds it next).
int free_udp_port() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a));
  socklen_t len = sizeof(a);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

// The shipped robot on a udp bus with a robot answering it, and a rollout of 0.5 + 0.5 s.
class RealtimeLoop : public ::testing::Test {
 protected:
  static RobotConfig relaxed() {
    RobotConfig c = load_robot_config(default_robot_config_path());
    c.safety.max_consecutive_overruns = 100;  // this shared machine may deschedule the loop
    c.safety.feedback_timeout_s = 0.5;
    return c;
  }
  RobotConfig config = relaxed();
  std::string uri = "udp:127.0.0.1:" + std::to_string(free_udp_port());
  AnsweringRobot robot{config, uri};
  std::unique_ptr<can::CanBus> bus = can::open_can_bus(uri);
  CanPlant plant{config, *bus, CanPlantOptions{0.2, false}};
  RolloutSettings settings = [] {
    RolloutSettings s;
    s.entrain_s = 0.5;
    s.eval_s = 0.5;
    return s;
  }();
};

TEST_F(RealtimeLoop, ARolloutOnTheCanPlantAllocatesNothingOnceActive) {
  ASSERT_EQ(plant.prepare(settings.entrain_s + settings.eval_s), std::nullopt);  // activation: may allocate
  AllocationWatch watch(plant);
  const RolloutResult result = run_rollout(watch, CpgParameters{}, settings, 1);
  watch.stop();
  plant.finish();
  ASSERT_FALSE(plant.fault_ended_rollout()) << plant.fault().value_or("");
  EXPECT_NEAR(result.sim_time_s, 1.0, 1e-9);
  EXPECT_EQ(watch.allocations_in_loop(), 0) << "heap allocations inside the real-time loop";
}

// The same over the other motor protocols (issue 31): ODrive's gains cache and Iq requests, moteus' CAN-FD
// register frames in the udp wire format, each joint's protocol object from the factory.
TEST(RealtimeLoopProtocols, ODriveAndMoteusRolloutsAllocateNothingOnceActive) {
  const std::string dir = default_robot_config_path().substr(0, default_robot_config_path().rfind('/') + 1);
  RobotConfig odrive = load_robot_config(dir + "odrive-quadruped.yaml");
  RobotConfig moteus = load_robot_config(default_robot_config_path());
  for (JointConfig& j : moteus.joints) {
    j.protocol = "moteus";
    j.moteus = {50.0, 1.0, moteus.host_id};
  }
  for (RobotConfig* config : {&odrive, &moteus}) {
    config->safety.max_consecutive_overruns = 100;
    config->safety.feedback_timeout_s = 0.5;
    for (JointConfig& j : config->joints) j.feedback_timeout_s.reset();
    const std::string uri = "udp:127.0.0.1:" + std::to_string(free_udp_port());
    AnsweringRobot robot{*config, uri};
    auto bus = can::open_can_bus(uri);
    CanPlant plant{*config, *bus, CanPlantOptions{0.2, false}};
    RolloutSettings settings;
    settings.entrain_s = 0.3;
    settings.eval_s = 0.3;
    settings.controller.control_rate_hz = config->control_rate_hz;
    ASSERT_EQ(plant.prepare(settings.entrain_s + settings.eval_s), std::nullopt) << config->joints[0].protocol;
    AllocationWatch watch(plant);
    run_rollout(watch, CpgParameters{}, settings, 1);
    watch.stop();
    plant.finish();
    ASSERT_FALSE(plant.fault_ended_rollout()) << config->joints[0].protocol << ": " << plant.fault().value_or("");
    EXPECT_EQ(watch.allocations_in_loop(), 0) << config->joints[0].protocol << ": heap allocations in the real-time loop";
  }
}

// The agent records every hardware rollout's trace (HardwareRunner::run): into room reserved before the
// loop, so recording allocates nothing in it either; ticks past the room are counted, not kept.
TEST_F(RealtimeLoop, RecordingTheTraceAllocatesNothingInTheLoop) {
  for (const std::size_t room : {std::size_t{502}, std::size_t{300}}) {  // the whole rollout (500 ticks), and less
    ASSERT_EQ(plant.prepare(settings.entrain_s + settings.eval_s), std::nullopt);
    domain::MeasuredTrace trace;
    std::uint64_t dropped = 0;
    const TraceSink sink = domain::record_trace_bounded(trace, room, dropped);
    AllocationWatch watch(plant);
    run_rollout(watch, CpgParameters{}, settings, 1, sink);
    watch.stop();
    ASSERT_FALSE(plant.fault_ended_rollout()) << plant.fault().value_or("");
    EXPECT_EQ(watch.allocations_in_loop(), 0) << "heap allocations while recording the trace (room " << room << ")";
    EXPECT_EQ(trace.ticks.size(), std::min<std::size_t>(room, 500));
    EXPECT_EQ(trace.ticks.size() + dropped, 500u);
    EXPECT_NEAR(trace.ticks.back().time_s, (trace.ticks.size() - 1) / 500.0, 1e-9);  // on the control grid
  }
  plant.finish();
}

}  // namespace
}  // namespace cpgmatch::robot

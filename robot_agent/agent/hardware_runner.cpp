#include "hardware_runner.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <mutex>

#include <fmt/format.h>

#include "cpgmatch/can/can_bus.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot/can_plant.hpp"
#include "cpgmatch/robot/realtime.hpp"
#include "cpgmatch/robot/robot_config.hpp"

namespace cpgmatch::robot {
namespace {

double thread_cpu_s() {
  struct timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

}  // namespace

struct HardwareRunner::Impl {
  explicit Impl(const HardwareRunnerOptions& o) : options(o), latch(o.robot_id) {}
  HardwareRunnerOptions options;
  RobotConfig config;
  std::unique_ptr<can::CanBus> bus;
  std::unique_ptr<CanPlant> plant;
  std::once_flag realtime_once;
  std::string realtime_warning;
  EstopLatch latch;
};

HardwareRunner::HardwareRunner(const HardwareRunnerOptions& options) : impl_(std::make_unique<Impl>(options)) {
  impl_->config = load_robot_config(options.robot_path);
  // A description the Plant cannot carry is refused before the bus. Any number of legs: a study brings its
  // robot's legs and gaits with its spec, and a study of another body is refused (study_robot_mismatch).
  if (auto why = impl_->config.plant_mismatch()) throw InputError(*why);
  if (impl_->config.emulator_only && options.can_uri.rfind("socketcan:", 0) == 0) {
    throw InputError(fmt::format("{}: emulator_only: true may not drive {} (its watchdog may be slower than the 20 ms "
                                 "safety target); use the robot's own description",
                                 options.robot_path, options.can_uri));
  }
  if (options.lockstep && !impl_->config.emulator_only) {
    throw InputError(fmt::format("--lockstep needs a robot description with emulator_only: true ({} is not)", options.robot_path));
  }
  impl_->bus = can::open_can_bus(options.can_uri, can::BusRole::kController);
  CanPlantOptions plant_options;
  plant_options.wait_for_every_reply = options.lockstep;
  impl_->plant = std::make_unique<CanPlant>(impl_->config, *impl_->bus, plant_options);
}

HardwareRunner::~HardwareRunner() {
  if (impl_ && impl_->plant) impl_->plant->finish();
}

std::optional<std::string> HardwareRunner::study_robot_mismatch(const RobotDescription& study_robot) const {
  return impl_->config.study_robot_mismatch(study_robot);
}

double HardwareRunner::control_rate_hz() const { return impl_->config.control_rate_hz; }

std::string HardwareRunner::robot_description() const { return impl_->config.robot; }

int HardwareRunner::leg_count() const { return impl_->config.leg_count(); }

std::string HardwareRunner::realtime_warning() const { return impl_->realtime_warning; }

void HardwareRunner::emergency_stop(const char* reason) { impl_->plant->emergency_stop(reason); }

StopOutcome HardwareRunner::stop_command(const StopRequest& request) {
  const StopOutcome outcome = impl_->latch.apply(request);
  // Latch first, then trip: a rollout that starts in between sees the latch after prepare() (which
  // clears the plant's trip) and stops there. A repeated stop trips again; the safe state is idempotent.
  if (outcome == StopOutcome::kLatched || outcome == StopOutcome::kAlreadyLatched) {
    const std::string reason = *impl_->latch.reason();
    impl_->plant->emergency_stop(reason.c_str());
  }
  return outcome;
}

std::optional<std::string> HardwareRunner::latched_stop() const { return impl_->latch.reason(); }

std::optional<HardwareRollout> HardwareRunner::latched_refusal() const {
  const std::optional<std::string> stop = impl_->latch.reason();
  if (!stop) return std::nullopt;
  HardwareRollout out;
  out.error = "refused: emergency stop latched: " + *stop + " (until cpgmatch estop --release or a restart)";
  out.outcome = HardwareOutcome::kRefused;
  return out;
}

HardwareRollout HardwareRunner::run(const CpgParameters& params, const RolloutSettings& requested, std::uint64_t seed) {
  if (std::optional<HardwareRollout> refused = latched_refusal()) return *refused;
  HardwareRollout out;
  if (auto why = impl_->config.envelope_violation(params)) {
    out.error = "refused: " + *why;
    return out;
  }
  RolloutSettings settings = requested;
  // The robot runs the controller at its own rate; run_rollout polls contacts at their configured rate
  // on top of it (250 Hz on 500 Hz by default).
  settings.controller.control_rate_hz = impl_->config.control_rate_hz;
  if (impl_->options.realtime) {
    std::call_once(impl_->realtime_once, [&] {
      impl_->realtime_warning = enter_realtime(impl_->options.fifo_priority).warning;
    });
  }
  // The trace's room, before the motors are on: a tick per control period of the whole rollout.
  const double expected_ticks = std::ceil((settings.entrain_s + settings.eval_s) * impl_->config.control_rate_hz) + 2.0;
  const TraceSink trace = domain::record_trace_bounded(
      out.trace, static_cast<std::size_t>(std::min<double>(expected_ticks, domain::kMaxTraceTicks)), out.trace_ticks_dropped);
  CanPlant& plant = *impl_->plant;
  const std::optional<std::string> not_ready = plant.activate(settings.entrain_s + settings.eval_s);
  // activate() clears the plant's trip, so a stop that came while it ran is read from the latch here.
  if (auto stop = impl_->latch.reason()) {
    plant.emergency_stop(stop->c_str());
    plant.deactivate();
    out.error = "emergency stop: " + *stop;
    out.outcome = HardwareOutcome::kPlantFault;
    return out;
  }
  if (not_ready) {
    plant.deactivate();
    out.error = "robot not ready: " + *not_ready;
    out.outcome = HardwareOutcome::kPlantFault;
    return out;
  }
  const double cpu_start = thread_cpu_s();
  try {
    out.result = run_rollout(plant, params, settings, seed, trace);
  } catch (const std::exception& e) {
    plant.emergency_stop("the rollout threw");
    plant.deactivate();
    out.error = fmt::format("rollout failed: {}", e.what());
    return out;
  }
  out.cpu_s = thread_cpu_s() - cpu_start;
  plant.deactivate();
  const LoopStats s = plant.loop_stats();
  out.loop = {s.ticks, s.jitter_p50_us, s.jitter_p99_us, s.jitter_max_us, s.overruns,
              s.feedback_latency_p50_us, s.feedback_latency_p99_us, s.feedback_latency_max_us,
              s.missing_replies, s.unexpected_frames};
  out.trace.source = fmt::format("robot rollout at {} Hz", impl_->config.control_rate_hz);
  if (plant.fault_ended_rollout()) {
    out.error = fmt::format("safe stop at t = {:.3f} s: {}", plant.state().time_s, plant.fault().value_or("?"));
    out.outcome = HardwareOutcome::kPlantFault;
    return out;
  }
  out.ok = true;
  out.outcome = HardwareOutcome::kRan;
  return out;
}

}  // namespace cpgmatch::robot

#include "cpgmatch/calibration/trace_replay.hpp"

#include <cmath>

#include <fmt/format.h>

#include "cpgmatch/contact_sensor.hpp"
#include "cpgmatch/controller.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/sim/ode_plant.hpp"

namespace cpgmatch::calibration {
namespace {

// The CSV keeps 4 decimals of an angle: a recomputed command within this of the trace's is the same one.
constexpr double kCommandTolerance_rad = 2e-4;

bool finite(const PlantState& s) {
  bool ok = std::isfinite(s.trunk.x_m) && std::isfinite(s.trunk.height_m) && std::isfinite(s.trunk.pitch_rad) &&
            std::isfinite(s.trunk.vx_mps);
  for (const auto& leg : s.legs) ok = ok && std::isfinite(leg.hip_angle_rad) && std::isfinite(leg.knee_flexion_rad);
  return ok;
}

}  // namespace

CommandSequence commands_of(const MeasuredTrace& trace, const CpgParameters& params, const RolloutSettings& settings,
                            std::size_t ticks) {
  const std::size_t n = ticks == 0 ? trace.ticks.size() : std::min(ticks, trace.ticks.size());
  const double period = 1.0 / settings.controller.control_rate_hz;
  if (trace.ticks.size() >= 2 && std::abs(trace.ticks[1].time_s - period) > 2e-4) {
    throw InputError(fmt::format("{}: ticks {} s apart, but the settings' control period is {} s", trace.source,
                                 trace.ticks[1].time_s, period));
  }
  CpgController controller(params, settings.controller);
  CommandSequence commands;
  commands.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const MeasuredTick& tick = trace.ticks[i];
    if (tick.legs.size() != controller.leg_count()) {
      throw InputError(fmt::format("{}: the trace has {} legs, the settings' robot {}", trace.source, tick.legs.size(),
                                   controller.leg_count()));
    }
    PerLeg<bool> contacts(tick.legs.size());
    for (std::size_t leg = 0; leg < tick.legs.size(); ++leg) contacts[leg] = tick.legs[leg].contact;
    const ControllerOutput out = controller.update(contacts);
    for (std::size_t leg = 0; leg < tick.legs.size(); ++leg) {
      const JointCommand& c = out.commands[leg];
      const MeasuredLeg& m = tick.legs[leg];
      const double hip_error = std::abs(c.hip_angle_rad - m.hip_target_rad);
      const double knee_error = std::abs(c.knee_flexion_rad - m.knee_target_rad);
      if (hip_error > kCommandTolerance_rad || knee_error > kCommandTolerance_rad) {
        throw InputError(fmt::format(
            "{}: at t = {:.4f} s the {} command ({:.4f}, {:.4f}) rad is not what these CPG parameters and settings "
            "give ({:.4f}, {:.4f}) rad: the trace was made with other ones",
            trace.source, tick.time_s, settings.controller.legs.names.at(leg), m.hip_target_rad, m.knee_target_rad, c.hip_angle_rad,
            c.knee_flexion_rad));
      }
    }
    commands.push_back(out.commands);
  }
  return commands;
}

std::optional<MeasuredTrace> replay(const sim::PlanarLegModel& model, const CommandSequence& commands,
                                    const ReplaySetup& setup) {
  sim::OdePlant plant(model, setup.terrain, setup.seed);
  const std::size_t legs = model.leg_count();
  ContactSensor sensor(setup.settings.contact_sensor, setup.seed, legs);
  const RolloutClock clock(plant, setup.settings);
  const double dt = plant.time_step_s();
  MeasuredTrace out;
  out.source = "replay";
  out.ticks.reserve(commands.size());
  PerLeg<bool> contacts(legs, true);
  ControllerOutput output;  // only its commands are used: the replay's sample for to_measured_tick
  // run_rollout's clock, so that a replay on the model that made the trace gives the trace again.
  for (long step = 0; out.ticks.size() < commands.size(); ++step) {
    if (const std::optional<PlantState> state = clock.sense(step, plant, sensor, contacts)) {
      if (!finite(*state)) return std::nullopt;
      output.commands = commands[out.ticks.size()];
      out.ticks.push_back(to_measured_tick(TraceSample{state->time_s, &*state, &output, &contacts}));
      plant.command(output.commands);
    }
    plant.advance(dt);
  }
  return out;
}

}  // namespace cpgmatch::calibration

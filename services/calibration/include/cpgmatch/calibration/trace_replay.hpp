// Replays a measured rollout on a simulated Morti: the same joint commands, tick by tick, on a model whose
// values calibration varies. Why replay the commands instead of re-running the controller: a closed loop
// reacts to the simulation's own contacts, so a small model change moves every later step and the two traces
// drift apart in phase; replaying what the robot was told keeps them in step, and what differs is the body's
// answer to the same commands, which is what the model values explain.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "cpgmatch/calibration/measured_trace.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/rollout.hpp"
#include "cpgmatch/sim/morti_model.hpp"
#include "cpgmatch/sim/terrain.hpp"

namespace cpgmatch::calibration {

// What the robot was told at each tick of a trace (hip passive included, which the CSV does not show).
using CommandSequence = std::vector<PerLeg<JointCommand>>;

// Re-runs the controller of `params` and `settings` on the trace's measured contacts: it is deterministic
// given them, so this gives the commands the robot received, at full precision. The first `ticks` ticks
// (all when 0). Throws InputError when a commanded angle differs from the trace's by more than the CSV's
// rounding (the trace was not made with these parameters or settings), or when the trace's tick period is
// not the settings' control period.
CommandSequence commands_of(const MeasuredTrace& trace, const CpgParameters& params, const RolloutSettings& settings,
                            std::size_t ticks = 0);

struct ReplaySetup {
  sim::TerrainSpec terrain;
  RolloutSettings settings;  // control rate and contact sensing (the same as the measured rollout's)
  std::uint64_t seed = 0;    // the simulated contact sensor's noise: fixed, so every replay sees the same
};

// Runs the commands on a fresh simulated Morti of `model` and returns what it measured at each tick; nothing
// when the simulation diverged (a non-finite state).
std::optional<MeasuredTrace> replay(const sim::PlanarLegModel& model, const CommandSequence& commands,
                                    const ReplaySetup& setup);

}  // namespace cpgmatch::calibration

// One rollout: the controller drives a Plant for entrain_s + eval_s seconds, and the cost is evaluated
// over the last eval_s. Physics, control and contact polling run at their own rates (1 kHz / 500 Hz /
// 250 Hz on Morti); the plant's time step sets the base rate and the others must divide it evenly.
#pragma once

#include <functional>
#include <optional>
#include <string>

#include "cpgmatch/contact_sensor.hpp"
#include "cpgmatch/controller.hpp"
#include "cpgmatch/cost.hpp"
#include "cpgmatch/energy.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/plant.hpp"

namespace cpgmatch {

class YamlReader;

struct RolloutSettings {
  double entrain_s = 10.0;
  double eval_s = 10.0;
  ControllerConfig controller;
  ContactSensorConfig contact_sensor;
  CostConfig cost;
};

// How a rollout ended. Only kCompleted and kFell measure the gait; a plant fault or a diverged simulation
// says nothing about it, and the optimizer must not learn from it (the trial is run again instead).
enum class RolloutOutcome { kCompleted, kFell, kPlantFault, kDiverged };
const char* to_string(RolloutOutcome outcome);  // completed | fell | plant_fault | diverged

struct RolloutResult {
  RolloutOutcome outcome = RolloutOutcome::kCompleted;
  std::string outcome_message;  // plant_fault / diverged: what happened, at which time
  CostBreakdown breakdown;  // cost replaced by the fall cost when fell
  double cost = 0.0;
  bool fell = false;
  double fall_time_s = -1.0;
  double sim_time_s = 0.0;
  double wall_time_s = 0.0;
  // How closely the hips followed the pattern: root mean square over legs and control ticks of the hip angle
  // commanded at one tick minus the angle measured at the next, radians. Counted from the end of the
  // start-up ramp to the end of the rollout (or the fall), over ticks whose hip motor was driving (not
  // passive for a reflex); -1 when there was no such tick (a fall during the ramp). A pattern that asks more
  // of a loaded hip than its motor's torque-speed line and its position loop give lags by tenths of a
  // radian; a matched trot's by about 0.1 (docs/model.md, "Which random gaits the feedback breaks").
  double hip_tracking_rms_rad = -1.0;
  // What the motors spent over the evaluation window (energy.hpp): positive work, Joule loss, electrical
  // energy, cost of transport, signed mean torques. Up to the fall, when it fell.
  EnergyMeasures energy;
  CpgParameters params;
};

// Everything the trace CSV shows, once per control tick.
struct TraceSample {
  double time_s;
  const PlantState* state;
  const ControllerOutput* output;
  const PerLeg<bool>* contacts;
};
using TraceSink = std::function<void(const TraceSample&)>;

// The rollout's clock: the plant's physics step is the base rate; the contact sensor is polled and the
// controller runs every so many steps. run_rollout and the calibration's replay both step a plant through
// it, so a replay samples and commands exactly when the rollout did.
class RolloutClock {
 public:
  // Throws InputError when the control or polling rate does not divide the physics rate.
  RolloutClock(const Plant& plant, const RolloutSettings& settings);
  // At physics step `step` (before advancing it): polls `sensor` into `contacts` when it is due, and returns
  // the plant's state when the controller runs at this step (nothing otherwise).
  std::optional<PlantState> sense(long step, const Plant& plant, ContactSensor& sensor, PerLeg<bool>& contacts) const;
  int control_every() const { return control_every_; }

 private:
  int control_every_ = 1;
  int contact_every_ = 1;
};

// Runs a rollout on `plant`. `seed` drives the contact-sensor noise. Never throws for a bad gait: a fall
// ends the rollout with the fall cost (outcome kFell); a non-finite plant state ends it as kDiverged and a
// plant fault as kPlantFault, both with the fall cost as a placeholder that must not be learned from.
RolloutResult run_rollout(Plant& plant, const CpgParameters& params, const RolloutSettings& settings,
                          std::uint64_t seed, const TraceSink& trace = {});

// Loads rollout settings from YAML (keys: entrain_s, eval_s, controller{...}, contact_sensor{...},
// cost{...}); every key is optional and defaults to the paper's value.
RolloutSettings load_rollout_settings(const std::string& path);
// The same from a parsed tree (a study spec's section); errors name the reader's source and field.
RolloutSettings parse_rollout_settings(const YamlReader& reader);

// Loads a parameter file (a mapping of parameter names to numbers) over `base`.
CpgParameters load_parameters(const std::string& path, CpgParameters base = {});
CpgParameters parse_parameters(const YamlReader& reader, CpgParameters base = {});

// Writes the trace as CSV; opens the file and returns a sink that appends one row per sample.
// Columns per leg are named by the robot's legs (`leg_names`, in leg order).
TraceSink make_csv_trace(const std::string& path, const std::vector<std::string>& leg_names);

}  // namespace cpgmatch

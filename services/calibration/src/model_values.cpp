#include "cpgmatch/calibration/model_values.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/split.hpp"

namespace cpgmatch::calibration {

const std::vector<ModelValue>& calibratable_values() {
  using M = sim::PlanarLegModel;
  // Bounds: a factor of about 3 around the model's assumed value, within what the part could physically
  // be (configs/model/morti.yaml gives the nominal values and their sources).
  static const std::vector<ModelValue> values = {
      {"knee_spring.stiffness_nm_per_rad", "N m/rad", 4.0, 45.0,
       "SLIP scaling k L/(m g) = 10-20 gives 15; a third to three times that",
       [](M& m) -> double& { return m.knee_spring.stiffness_nm_per_rad; }},
      {"knee_spring.damping_nm_s_per_rad", "N m s/rad", 0.02, 0.8,
       "damping ratio ~0.03 (bare steel spring) to ~1 (critical) against the knee's 0.01 kg m^2",
       [](M& m) -> double& { return m.knee_spring.damping_nm_s_per_rad; }},
      {"biarticular_spring.stiffness_nm_per_rad", "N m/rad", 1.0, 15.0,
       "weaker than the knee spring, same order of magnitude",
       [](M& m) -> double& { return m.biarticular_spring.stiffness_nm_per_rad; }},
      // A spring across the knee, beside its motor (odrive-quadruped's): a robot's description only. Bounds as
      // the series knee spring's; a robot's calibration bounds it around its own value (robot_values.cpp).
      {"knee_parallel_spring.stiffness_nm_per_rad", "N m/rad", 0.5, 45.0,
       "a weak return spring to the stiffest knee spring of this size class",
       [](M& m) -> double& { return m.knee_parallel_spring.stiffness_nm_per_rad; }, false},
      {"knee_parallel_spring.damping_nm_s_per_rad", "N m s/rad", 0.0, 0.8,
       "a bare steel spring (no damping) to a critically damped knee",
       [](M& m) -> double& { return m.knee_parallel_spring.damping_nm_s_per_rad; }, false},
      {"trunk.mass_kg", "kg", 1.5, 6.0, "the bare carbon frame to a trunk with battery, computer and payload",
       [](M& m) -> double& { return m.trunk_mass_kg; }},
      {"contact.friction", "", 0.1, 1.5, "rubber on a wet or dusty belt (0.1-0.3) to rubber on clean rubber (1.5)",
       [](M& m) -> double& { return m.contact.friction; }},
      {"contact.stiffness_n_per_m", "N/m", 5e3, 2e5, "a soft foam pad to a hard rubber dome",
       [](M& m) -> double& { return m.contact.stiffness_n_per_m; }},
      {"contact.damping_n_s_per_m", "N s/m", 50.0, 2000.0, "a bouncing contact (zeta ~0.1) to an overdamped one (zeta ~2)",
       [](M& m) -> double& { return m.contact.damping_n_s_per_m; }},
      {"hip_motor.no_load_speed_rad_s", "rad/s", 4.0, 30.0, "a 120:1 to a 15:1 gearbox on this motor",
       [](M& m) -> double& { return m.hip_motor.no_load_speed_rad_s; }},
      {"hip_motor.coulomb_friction_nm", "N m", 0.0, 0.8,
       "none to a back-driven high-ratio gearbox (a fifth of the stall torque)",
       [](M& m) -> double& { return m.hip_motor.coulomb_friction_nm; }},
      {"hip_motor.viscous_friction_nm_s_per_rad", "N m s/rad", 0.0, 0.1,
       "none to cold grease that eats most of the torque at the no-load speed",
       [](M& m) -> double& { return m.hip_motor.viscous_friction_nm_s_per_rad; }},
      {"hip_motor.reflected_inertia_kg_m2", "kg m^2", 0.0, 0.02,
       "none to a 90:1 gearbox on this rotor",
       [](M& m) -> double& { return m.hip_motor.reflected_inertia_kg_m2; }},
      {"leg.knee_joint_friction_nm", "N m", 0.0, 0.3, "a free bearing to a knee as stiff as the hip gearbox",
       [](M& m) -> double& { return m.knee_joint_friction_nm; }},
      {"foot_sensor.sensitivity", "", 0.3, 1.5, "a dome that passes a third of the force to one that amplifies it",
       [](M& m) -> double& { return m.foot_sensor.sensitivity; }},
      {"foot_sensor.time_constant_s", "s", 0.0, 0.05, "no lag to a reading slower than a tenth of a step",
       [](M& m) -> double& { return m.foot_sensor.time_constant_s; }},
  };
  return values;
}

const ModelValue& find_model_value(const std::string& name) {
  const auto& values = calibratable_values();
  const auto it = std::find_if(values.begin(), values.end(), [&](const ModelValue& v) { return v.name == name; });
  if (it != values.end()) return *it;
  std::vector<std::string> names;
  for (const auto& v : values) names.push_back(v.name);
  throw InputError(fmt::format("'{}' is not a model value calibration can fit; known: {}", name, fmt::join(names, ", ")));
}

std::vector<const ModelValue*> parse_model_value_list(const std::string& comma_separated) {
  std::vector<const ModelValue*> out;
  for (const std::string_view part : split_on(comma_separated, ',')) {
    const std::string name(part);
    if (name.empty()) throw InputError(fmt::format("'{}': an empty name in the list", comma_separated));
    const ModelValue* value = &find_model_value(name);
    if (std::find(out.begin(), out.end(), value) != out.end()) {
      throw InputError(fmt::format("'{}' is named twice", name));
    }
    out.push_back(value);
  }
  return out;
}

}  // namespace cpgmatch::calibration

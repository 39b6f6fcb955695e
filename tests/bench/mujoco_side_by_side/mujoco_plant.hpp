// A cpgmatch Plant over MuJoCo 2.2.2: Morti's URDF as MuJoCo imports it, held in the sagittal plane, with
// the actuation of cpgmatch's ODE plant (workers/sim/src/ode_plant.cpp) written again on MuJoCo's joints.
// For the side-by-side benchmark only (docs/bench/mujoco.md); the product never links MuJoCo.
#pragma once

#include <memory>
#include <string>

#include "cpgmatch/plant.hpp"
#include "cpgmatch/robot_description.hpp"
#include "cpgmatch/sim/morti_model.hpp"

namespace cpgmatch::bench {

// MuJoCo's own solver settings, to see what its speed depends on (defaults: MuJoCo's).
struct MujocoSolver {
  std::string solver = "newton";  // newton | cg | pgs
  int iterations = 100;           // MuJoCo's default
};

class MujocoPlant : public Plant {
 public:
  // `robot`: the description whose URDF MuJoCo loads; `model`: the same robot as the ODE plant sees it
  // (springs, motors, contact; sim::planar_leg_model(robot)). Throws std::runtime_error with MuJoCo's
  // message when the URDF or the generated MJCF does not load.
  MujocoPlant(const RobotDescription& robot, const sim::PlanarLegModel& model, const MujocoSolver& solver = {});
  ~MujocoPlant() override;

  void command(const PerLeg<JointCommand>& commands) override;
  void advance(double dt_s) override;
  PlantState state() const override;
  double time_step_s() const override;
  std::optional<EnergyModel> energy_model() const override;

  // The MJCF the plant was built from (MuJoCo's own export of the URDF, plus the rail and the floor).
  const std::string& mjcf() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cpgmatch::bench

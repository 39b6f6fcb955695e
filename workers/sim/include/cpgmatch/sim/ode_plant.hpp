// Morti in ODE: a Plant whose physics runs in one private ODE world.
//
// Layout: the sagittal plane is the world XY plane (x forward, y up, gravity -y); a Plane2D joint on the
// trunk gives the rail's three degrees of freedom (forward, vertical, pitch). Legs hang on hinges whose
// axes are the plane normal, so they stay in the plane without further constraints. Only the four toe
// spheres collide, and only with the terrain.
//
// Springs and the hip PD are explicit torques (accurate at 1 kHz for these inertias, see the model YAML);
// joint range limits are ODE hinge stops (implicit, never explode). The solver is dWorldStep: the
// iterative QuickStep lets a standing legged robot sag.
//
// Thread safety: one OdePlant must be used by one thread. Debian's ODE has no thread-local collision
// caches, so cpgmatch runs parallel rollouts as separate processes.
#pragma once

#include <memory>

#include "cpgmatch/plant.hpp"
#include "cpgmatch/sim/morti_model.hpp"
#include "cpgmatch/sim/terrain.hpp"

namespace cpgmatch::sim {

class OdePlant final : public Plant {
 public:
  OdePlant(const PlanarLegModel& model, const TerrainSpec& terrain, std::uint64_t seed);
  ~OdePlant() override;
  OdePlant(const OdePlant&) = delete;
  OdePlant& operator=(const OdePlant&) = delete;

  void command(const PerLeg<JointCommand>& commands) override;
  void advance(double dt_s) override;
  PlantState state() const override;
  double time_step_s() const override;
  // The model's hip and knee motor lines and its total mass.
  std::optional<EnergyModel> energy_model() const override;
  // The model's health: the largest distance between the two halves of any leg joint (metres), i.e. how far
  // the solver lets a joint drift apart; some tens of micrometres on a sound model.
  double largest_joint_gap_m() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cpgmatch::sim

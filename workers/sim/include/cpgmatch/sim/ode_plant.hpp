// A legged robot in ODE: a Plant whose physics runs in one private ODE world.
//
// Layout: the sagittal plane is the world XY plane (x forward, y up, gravity -y; z = x cross y points right).
// A planar robot (on a rail or boom: model.planar) stays in it: its legs are two-row pins (LegJoint) and
// every body is projected back onto the plane after each step, so the trunk moves forward, up and pitches
// only. A free robot stands on its own: ODE hinges about z join its legs, each leg at its hip's sideways
// place, and its trunk also rolls, turns and drifts (TrunkState::roll_rad, yaw_rad, lateral_m). Only the toe
// spheres collide, and only with the terrain.
//
// Springs and the hip PD are explicit torques (accurate at 1 kHz for these inertias, see the model YAML);
// joint range limits are ODE stop motors (implicit, never explode). The solver is dWorldStep: the
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

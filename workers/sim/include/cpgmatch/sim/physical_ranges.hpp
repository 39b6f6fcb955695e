// Physical ranges of a robot model's values, checked before any rollout.
//
// The parser's "> 0" lets through 1e308 kg or 1e-320 kg, which ODE cannot step (its quaternion
// normalisation asserts and the process aborts), and physics_rate_hz 1e9, which runs a rollout for days.
// These ranges are wide (a gram to a tonne, a millimetre to ten metres) around a legged robot of a few kg:
// a value outside is a typo or an attack, never a robot. Each range and its reason is next to its value in
// physical_ranges.cpp. Kept apart from the parser so that another robot description can check its own
// values with the same ranges (range_for).
#pragma once

#include <optional>
#include <string>

#include "cpgmatch/sim/morti_model.hpp"

namespace cpgmatch::sim {

// One kind of physical quantity and the values a model may give it (both ends inclusive).
struct PhysicalRange {
  double low;
  double high;
  const char* why;  // the reason for the range, shown in the message
};

enum class Quantity {
  kMass,            // kg
  kLength,          // m
  kInertia,         // kg m^2 (reflected rotor inertia about a joint)
  kJointStiffness,  // N m/rad
  kJointDamping,    // N m s/rad
  kContactStiffness,  // N/m
  kContactDamping,    // N s/m
  kFriction,        // Coulomb coefficient (1)
  kTorque,          // N m (stall torque, dry friction)
  kSpeed,           // rad/s
  kGain,            // N m/rad (position gain)
  kBandwidth,       // 1/s (position loop)
  kAngle,           // rad
  kSensitivity,     // 1
  kTimeConstant,    // s
  kPhysicsRate,     // Hz
  kGravity,         // m/s^2
};

const PhysicalRange& range_for(Quantity q);

// A value outside its range: where it is in the model file (section, e.g. "trunk", and key, e.g.
// "mass_kg") and what is wrong ("1e+308 kg is outside [0.001, 1000] kg: ...").
struct RangeProblem {
  std::string section;
  std::string key;
  std::string message;
};

// The first value of `m` outside its range, or nothing when every value is in range.
std::optional<RangeProblem> check_physical_ranges(const PlanarLegModel& m);

}  // namespace cpgmatch::sim

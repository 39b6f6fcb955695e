// Where each model value calibration fits lives in a robot's description: the one mapping from a
// ModelValue (a field of sim::PlanarLegModel) to the robot.yaml entry or URDF element that planar_leg_model
// reads it from, so that a fitted value is written back where the description says it.
//
//   knee_spring.*           drives.knee.stiffness_nm_per_rad / damping_nm_s_per_rad   (a series-elastic knee)
//   knee_parallel_spring.*  parallel_springs[i].*, the spring between the hip's and the knee's links
//   biarticular_spring.*    parallel_springs[i].*, the spring between the hip's and the ankle's links
//   trunk.mass_kg           the URDF's root link: <inertial><mass value=...>
//   contact.*, foot_sensor.*  the sections of the same name
//   hip_motor.*             motors.M.*, M the hip drive's motor (refused when the knee's model reads it too)
//   leg.knee_joint_friction_nm  drives.knee.joint_friction_nm
#pragma once

#include <string>
#include <vector>

#include "cpgmatch/calibration/model_values.hpp"
#include "cpgmatch/robot_description.hpp"

namespace cpgmatch::calibration {

struct RobotValueSite {
  enum class File { kRobotYaml, kUrdfTrunkMass };
  File file = File::kRobotYaml;
  std::vector<std::string> yaml_path;  // keys from robot.yaml's root; a list's index as its decimal digits
  std::string label;                   // "parallel_springs[0].stiffness_nm_per_rad", for messages and notes
};

// Where `value` lives in `robot`. InputError naming the value and the robot when the robot has no such part
// (a position-PD knee has no series spring, a two-segment leg no biarticular spring), when robot.yaml leaves
// the entry out (the loader's default stands in; there is no line to rewrite), or when the value would be
// written to a part the model reads for another value too (a motor that drives the hip and the knee).
RobotValueSite robot_value_site(const ModelValue& value, const RobotDescription& robot);

// The values to fit on `robot`, each checked to have a site (robot_value_site), with bounds for this robot:
// Morti's bounds are a factor of about 3 around Morti's values, so a value that scales with the robot's size
// (masses, stiffnesses, damping, motors, frictions in N m) is bounded a factor of 3 around the robot's own
// value (`start`, the model its description builds); a dimensionless or size-free one (a friction
// coefficient, the sensor's sensitivity and lag) keeps its range. The caller keeps the returned vector alive
// while CalibrationOptions points into it.
std::vector<ModelValue> robot_model_values(const std::vector<const ModelValue*>& values, const RobotDescription& robot,
                                           const sim::PlanarLegModel& start);

// What `cpgmatch calibrate` fits for a robot study without --params: the knee's spring the robot has (its
// series spring, else its spring across the knee) and the trunk mass, the pair a gait's traces tell apart.
std::string default_robot_value_list(const RobotDescription& robot);

}  // namespace cpgmatch::calibration

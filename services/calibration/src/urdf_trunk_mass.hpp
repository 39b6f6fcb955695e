// The URDF of a robot whose trunk mass was fitted: the root link's <mass value> set to the estimate and its
// <inertia> scaled by the same ratio, with a comment saying why; every other byte as written. Textual on
// purpose (one attribute each: a URDF writer would drop the author's comments and layout); the caller parses
// the result again with the project's loader. Private to services/calibration.
#pragma once

#include <string>

#include "cpgmatch/calibration/calibration.hpp"
#include "cpgmatch/robot_description.hpp"

namespace cpgmatch::calibration {

// InputError naming the URDF and the link when the root link has no <inertial> with <mass> and <inertia>.
std::string urdf_with_trunk_mass(const std::string& urdf, const RobotDescription& robot, const FittedValue& mass,
                                 const CalibrationResult& result);

}  // namespace cpgmatch::calibration

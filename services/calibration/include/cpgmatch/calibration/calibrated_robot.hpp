// Writes a calibrated robot: the robot's folder again (robot.yaml and its URDF), every fitted value rewritten
// where the description holds it (robot_values.hpp), its comments and sources kept, each fitted entry with its
// estimate, standard deviation and the misfit before and after (as a calibrated model file's). A fitted trunk
// mass is the URDF root link's <mass>, its inertia tensor scaled by the same ratio.
#pragma once

#include <string>
#include <vector>

#include "cpgmatch/calibration/calibration.hpp"
#include "cpgmatch/robot_description.hpp"

namespace cpgmatch::calibration {

struct CalibratedRobot {
  std::string robot_yaml;
  std::string urdf;
  std::string urdf_file;  // the file name robot.yaml's `urdf:` gives it, relative to the folder
};

// The calibrated texts of `robot` (its texts as a study spec holds them); `robot_source` names where the start
// came from in the header, `trace_sources` the traces. Checks that the texts parse as a robot whose model
// (sim::planar_leg_model) holds each estimate; InputError naming the value when it cannot be rewritten (an
// entry written as a block map, or one robot.yaml lacks: robot_value_site).
CalibratedRobot calibrated_robot(const RobotDescription& robot, const std::string& robot_source,
                                 const CalibrationResult& result, const std::vector<std::string>& trace_sources);

// Writes the folder `dir` (made if missing; its robot.yaml and URDF replaced) and returns the robot loaded
// back from it with the project's loader (load_robot). InputError naming the folder when it cannot be written.
RobotDescription write_calibrated_robot(const std::string& dir, const CalibratedRobot& files);

}  // namespace cpgmatch::calibration

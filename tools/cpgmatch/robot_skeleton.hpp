// `cpgmatch robot init`: a robot.yaml skeleton from a URDF, as CHAMP's setup assistant makes one. It names
// every joint and link of the URDF, guesses the legs (a hip hanging from the trunk, a knee after it, an
// optional ankle, the last link as the foot) and their groups (by the hips' fore-aft position), proposes
// gaits for the leg count, and marks with FILL_IN what only the user knows (motors, springs, gains): a FILL_IN
// left in is refused by `cpgmatch robot check`, naming its line.
#pragma once

#include <string>

#include "cpgmatch/robot_description_loader.hpp"

namespace cpgmatch::cli {

struct GuessedLeg {
  std::string name, group, hip, knee, ankle, foot;
  double hip_x_m = 0.0, hip_y_m = 0.0;
};

// The legs as the URDF's tree suggests them, front to back, left before right.
std::vector<GuessedLeg> guess_legs(const UrdfModel& urdf);

std::string robot_yaml_skeleton(const UrdfModel& urdf, const std::string& urdf_file_name);

}  // namespace cpgmatch::cli

// A study's robot: `robot: NAME` (a shipped robot, configs/robots/NAME/) or `robot: path/to/robot.yaml` (or
// its folder, relative to the study file) in a study file.
//
// A shipped robot the optimizer resolves from its own release, as it does the default model and settings. A
// robot of the user's own the submitting client reads (with_robot_files) and sends with the study, as it does
// a model file: the optimizer never reads a file a client names, and a worker needs no copy of the robot,
// since the spec holds the robot's whole content (both texts) under its hash.
#pragma once

#include <string>

namespace cpgmatch::study {

// The keys the client appends with the robot's two texts; written by the client only, never by hand.
inline constexpr const char* kRobotYamlTextKey = "robot_yaml_text";
inline constexpr const char* kRobotUrdfTextKey = "robot_urdf_text";

// True when a `robot:` value can name a shipped robot (a plain name: no '/', no '.'), false for a path.
bool names_shipped_robot(const std::string& robot);

// When the study file's `robot` is a path (or a plain name of a folder beside the study file): the study text with the robot's robot.yaml and URDF texts
// appended under kRobotYamlTextKey and kRobotUrdfTextKey (the study's own lines unchanged). Otherwise the text
// as it is. Throws InputError naming the study file, its line and the robot's own file:line when the robot
// cannot be read or does not check.
std::string with_robot_files(const std::string& study_yaml, const std::string& study_path);

// Every file a study names that its client sends: its model file (model_file.hpp) and its robot.
std::string with_named_files(const std::string& study_yaml, const std::string& study_path);

}  // namespace cpgmatch::study

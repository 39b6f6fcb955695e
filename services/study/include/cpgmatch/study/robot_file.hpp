// A study's robot: `robot: NAME` (a shipped robot, configs/robots/NAME/) or `robot: path/to/robot.yaml` (or
// its folder, relative to the study file) in a study file.
//
// A shipped robot the optimizer resolves from its own release, as it does the default model and settings. A
// robot of the user's own the submitting client reads (with_robot_files) and sends with the study, as it does
// a model file: the optimizer never reads a file a client names, and a worker needs no copy of the robot,
// since the spec holds the robot's whole content (both texts) under its hash.
#pragma once

#include <map>
#include <string>

#include "cpgmatch/bo/search_space.hpp"
#include "cpgmatch/robot_description_loader.hpp"  // names_shipped_robot, with the description

namespace cpgmatch::study {

// The keys the client appends with the robot's two texts; written by the client only, never by hand.
inline constexpr const char* kRobotYamlTextKey = "robot_yaml_text";
inline constexpr const char* kRobotUrdfTextKey = "robot_urdf_text";

// Whether a `robot:` value names a shipped robot: cpgmatch::names_shipped_robot (robot_description_loader.hpp).

// When the study file's `robot` is a path (or a plain name of a folder beside the study file): the study text with the robot's robot.yaml and URDF texts
// appended under kRobotYamlTextKey and kRobotUrdfTextKey (the study's own lines unchanged). Otherwise the text
// as it is. Throws InputError naming the study file, its line and the robot's own file:line when the robot
// cannot be read or does not check.
std::string with_robot_files(const std::string& study_yaml, const std::string& study_path);

// A robot's search space as the optimizer's, with the values of `preset` (a preset's CPG parameter values, or
// none) fixed on every parameter the robot does not search: every answer and export then names the whole gait
// it walked. The one definition for studies (the robot's "default" preset) and `optimize --robot --preset`.
bo::SearchSpace robot_search_space(const RobotDescription& robot, const std::map<std::string, double>* preset);

// Every file a study names that its client sends: its model file (model_file.hpp) and its robot.
std::string with_named_files(const std::string& study_yaml, const std::string& study_path);

}  // namespace cpgmatch::study

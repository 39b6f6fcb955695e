// Reads a robot description (a URDF and the robot.yaml beside it) with urdfdom and yaml-cpp, and checks it.
//
// Every problem is an InputError naming the element and where it is: "robot.yaml:14: field 'legs[2].knee':
// joint 'HL_knee_joint' is not in robot.urdf", "robot.urdf:31: link 'FL_foot': mass must be > 0 kg".
// Executables turn it into exit code 2; the optimizer service refuses a study with it at submit.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "cpgmatch/robot_description.hpp"

namespace cpgmatch {

// The folder of shipped robots: $CPGMATCH_CONFIG_DIR/robots, else the build's configs/robots.
std::filesystem::path shipped_robots_dir();
// Names of the shipped robots (folders of shipped_robots_dir() that hold a robot.yaml), sorted.
std::vector<std::string> shipped_robot_names();

// True when `name_or_path` can name a shipped robot (a plain name: no '/', no '.'), false for a path. A plain
// name that is also a file or folder where it is looked for means that file (the user's own robot wins).
bool names_shipped_robot(const std::string& name_or_path);

// `name_or_path`: a shipped robot's name ("morti"), a folder holding robot.yaml, or a robot.yaml path.
// The URDF is the file robot.yaml's `urdf:` key names, relative to robot.yaml's folder. The path may also be
// an overlay, a robot.yaml with `base:` and `set:` that changes a few of another robot's values (the
// reality-gap scenarios configs/robots/morti/scenarios/*.yaml; src/robot_overlay.hpp says how): the result is
// that robot with those values, its yaml_text the merged robot.yaml, its URDF the base's.
RobotDescription load_robot(const std::string& name_or_path);

// The same from the two texts (a study spec carries them); the sources stand in for file names in messages.
RobotDescription parse_robot(const std::string& yaml_text, const std::string& yaml_source,
                             const std::string& urdf_text, const std::string& urdf_source);

// The URDF alone: links, joints and the root, checked to be a tree whose links all have a positive mass
// and an inertia. Used by parse_robot and by `cpgmatch robot init` (which has no robot.yaml yet).
struct UrdfModel {
  std::string robot_name;
  std::string root_link;
  std::vector<LinkDescription> links;
  std::vector<JointDescription> joints;
};
UrdfModel parse_urdf(const std::string& urdf_text, const std::string& urdf_source);

}  // namespace cpgmatch

#include "cpgmatch/controller.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch {

// Sections a robot.yaml and a model file (workers/sim's PlanarLegModel) share, read one way for both. A value
// is a bare number or {value: X, source: "..."}; `fallback` holds what an absent key keeps.
double physical_value(const YamlReader& r, const std::string& key, double fallback);
double positive_value(const YamlReader& r, const std::string& key, double fallback);
double non_negative_value(const YamlReader& r, const std::string& key, double fallback);
ContactDescription parse_contact(const YamlReader& section, ContactDescription fallback);
FootSensorDescription parse_foot_sensor(const YamlReader& section, FootSensorDescription fallback);
// physics_rate_hz and gravity_m_s2 of a `simulation:` section.
void parse_simulation(const YamlReader& section, double& physics_rate_hz, double& gravity_m_s2);

// The controller's view of the robot: its legs (names, groups) and its gaits. The gait `config.gait` names
// is kept when the robot has it; otherwise the robot's default gait (its first) is used.
void apply_robot_legs(ControllerConfig& config, const RobotDescription& robot);

}  // namespace cpgmatch

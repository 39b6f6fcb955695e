// A robot description (configs/robots/NAME/) applied to a simulation job and turned into a search space, for
// the commands that run rollouts of any robot: `eval-rollout --robot` and `optimize --objective rollout --robot`.
#pragma once

#include <map>
#include <string>

#include "cpgmatch/bo/search_space.hpp"
#include "cpgmatch/robot_description.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"

namespace cpgmatch::cli {

// The robot's preset of that name; an empty name means the robot's "default" preset, or none (nullptr) when it
// has no preset of that name. A named preset the robot lacks is an InputError listing the ones it has.
const std::map<std::string, double>* robot_preset(const RobotDescription& robot, const std::string& name);

// The robot's plant and legs (and gaits) on the job; the preset's values on its parameters. `gait`, when given,
// must be one of the robot's gaits; empty keeps the settings' gait if the robot has it, else the robot's default
// (as `rollout --robot` and `robot check` do).
void apply_robot(sim::SimRolloutJob& job, const RobotDescription& robot, const std::string& preset,
                 const std::string& gait);

// The robot's search_space as the optimizer's; every parameter of the preset not searched is passed on fixed,
// so an objective gets the whole parameter set the preset walks with.
bo::SearchSpace robot_search_space(const RobotDescription& robot, const std::string& preset);

}  // namespace cpgmatch::cli

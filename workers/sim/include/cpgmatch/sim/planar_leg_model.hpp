// The simulation's planar leg model, built from a robot description (URDF + robot.yaml).
//
// OdePlant simulates a trunk on a planar rail with legs of two or three segments (hip -> femur -> knee ->
// shank [-> ankle -> foot]) whose values it takes from a PlanarLegModel. This reads those values from a robot
// description instead of a hand-written model file: segment lengths from the joint origins, masses from the
// links, the standing pose from the joints' origin rotations, stops from the joint limits, the toe from the
// foot's collision sphere, the trunk from its collision box; springs, motors, contact and the foot sensor
// from robot.yaml. Morti from configs/robots/morti/ gives exactly configs/model/morti.yaml's model
// (tests/physics/test_robot_description.cpp).
//
// What this version's plant builds, and so what this accepts (anything else is an InputError naming why):
// any number of legs whose hips sit anywhere along the trunk's x axis, all legs alike, planar joint axes
// (about y), a PD-driven hip, a series-elastic knee, and a passive ankle held by a parallel spring to the
// femur. Each restriction falls as the plant learns to build more.
#pragma once

#include "cpgmatch/robot_description.hpp"
#include "cpgmatch/sim/morti_model.hpp"

namespace cpgmatch::sim {

PlanarLegModel planar_leg_model(const RobotDescription& robot);

// The trunk's height above flat ground when the robot stands in its URDF pose with the lowest foot sphere
// just touching the ground (metres): the URDF's forward kinematics, in the sagittal plane.
double standing_trunk_height_m(const RobotDescription& robot);

}  // namespace cpgmatch::sim

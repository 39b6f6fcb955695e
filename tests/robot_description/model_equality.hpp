// Every value of the simulation's model built from a robot description equals a model file's, to 1e-12 relative
// (what two files that say the same robot in two forms may differ by: a URDF's positions are computed, not copied).
#pragma once

#include <algorithm>
#include <cmath>
#include <tuple>
#include <utility>

#include <gtest/gtest.h>

#include "cpgmatch/sim/morti_model.hpp"

namespace cpgmatch::testing_support {

inline void expect_models_equal(const sim::PlanarLegModel& from_urdf, const sim::PlanarLegModel& by_hand) {
  auto expect_near = [](double a, double b, const char* what) { EXPECT_NEAR(a, b, 1e-12 * std::max(1.0, std::abs(b))) << what; };
  expect_near(from_urdf.trunk_mass_kg, by_hand.trunk_mass_kg, "trunk mass");
  expect_near(from_urdf.trunk_length_m, by_hand.trunk_length_m, "trunk length");
  expect_near(from_urdf.trunk_height_m, by_hand.trunk_height_m, "trunk height");
  expect_near(from_urdf.trunk_depth_m, by_hand.trunk_depth_m, "trunk depth");
  expect_near(from_urdf.hip_spacing_m, by_hand.hip_spacing_m, "hip spacing");
  for (auto [a, b, what] : {std::tuple{from_urdf.femur, by_hand.femur, "femur"}, std::tuple{from_urdf.shank, by_hand.shank, "shank"},
                            std::tuple{from_urdf.foot, by_hand.foot, "foot"}}) {
    expect_near(a.length_m, b.length_m, what);
    expect_near(a.mass_kg, b.mass_kg, what);
  }
  expect_near(from_urdf.toe_radius_m, by_hand.toe_radius_m, "toe radius");
  expect_near(from_urdf.femur_mount_angle_rad, by_hand.femur_mount_angle_rad, "mount angle");
  expect_near(from_urdf.knee_stand_flexion_rad, by_hand.knee_stand_flexion_rad, "knee standing flexion");
  expect_near(from_urdf.knee_min_flexion_rad, by_hand.knee_min_flexion_rad, "knee min");
  expect_near(from_urdf.knee_max_flexion_rad, by_hand.knee_max_flexion_rad, "knee max");
  expect_near(from_urdf.ankle_range_rad, by_hand.ankle_range_rad, "ankle range");
  expect_near(from_urdf.knee_joint_friction_nm, by_hand.knee_joint_friction_nm, "knee friction");
  expect_near(from_urdf.knee_spring.stiffness_nm_per_rad, by_hand.knee_spring.stiffness_nm_per_rad, "knee spring");
  expect_near(from_urdf.knee_spring.damping_nm_s_per_rad, by_hand.knee_spring.damping_nm_s_per_rad, "knee damping");
  expect_near(from_urdf.biarticular_spring.stiffness_nm_per_rad, by_hand.biarticular_spring.stiffness_nm_per_rad, "biarticular");
  expect_near(from_urdf.biarticular_spring.damping_nm_s_per_rad, by_hand.biarticular_spring.damping_nm_s_per_rad, "biarticular d");
  for (auto [a, b] : {std::pair{from_urdf.hip_motor, by_hand.hip_motor}, std::pair{from_urdf.knee_motor, by_hand.knee_motor}}) {
    expect_near(a.stall_torque_nm, b.stall_torque_nm, "stall");
    expect_near(a.no_load_speed_rad_s, b.no_load_speed_rad_s, "no load");
    expect_near(a.kp_nm_per_rad, b.kp_nm_per_rad, "kp");
    expect_near(a.kd_nm_s_per_rad, b.kd_nm_s_per_rad, "kd");
    expect_near(a.coulomb_friction_nm, b.coulomb_friction_nm, "coulomb");
    expect_near(a.viscous_friction_nm_s_per_rad, b.viscous_friction_nm_s_per_rad, "viscous");
    expect_near(a.reflected_inertia_kg_m2, b.reflected_inertia_kg_m2, "reflected");
  }
  expect_near(from_urdf.knee_motor_bandwidth_per_s, by_hand.knee_motor_bandwidth_per_s, "bandwidth");
  expect_near(from_urdf.contact.friction, by_hand.contact.friction, "friction");
  expect_near(from_urdf.contact.stiffness_n_per_m, by_hand.contact.stiffness_n_per_m, "contact k");
  expect_near(from_urdf.contact.damping_n_s_per_m, by_hand.contact.damping_n_s_per_m, "contact d");
  expect_near(from_urdf.foot_sensor.sensitivity, by_hand.foot_sensor.sensitivity, "sensitivity");
  expect_near(from_urdf.foot_sensor.time_constant_s, by_hand.foot_sensor.time_constant_s, "lag");
  expect_near(from_urdf.physics_rate_hz, by_hand.physics_rate_hz, "rate");
  expect_near(from_urdf.gravity_m_s2, by_hand.gravity_m_s2, "gravity");
}

}  // namespace cpgmatch::testing_support

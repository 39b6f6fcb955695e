#include "cpgmatch/sim/morti_model.hpp"

#include "cpgmatch/sim/physical_ranges.hpp"

#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::sim {
namespace {

// Each value in the model YAML is a mapping {value: X, unit: ..., source: ...}, or a bare number: read as a
// robot.yaml's are (robot_description_loader.hpp).
double value_of(const YamlReader& r, const std::string& key, double fallback) { return physical_value(r, key, fallback); }
double positive(const YamlReader& r, const std::string& key, double fallback) { return positive_value(r, key, fallback); }
double non_negative(const YamlReader& r, const std::string& key, double fallback) {
  return non_negative_value(r, key, fallback);
}

SegmentModel segment(const YamlReader& r, const std::string& key, SegmentModel fallback) {
  if (!r.has(key)) return fallback;
  const YamlReader s = r.child(key);
  s.reject_unknown_keys({"length_m", "mass_kg"});
  return {positive(s, "length_m", fallback.length_m), positive(s, "mass_kg", fallback.mass_kg)};
}

SpringModel spring(const YamlReader& r, const std::string& key, SpringModel fallback) {
  if (!r.has(key)) return fallback;
  const YamlReader s = r.child(key);
  s.reject_unknown_keys({"stiffness_nm_per_rad", "damping_nm_s_per_rad"});
  SpringModel out{positive(s, "stiffness_nm_per_rad", fallback.stiffness_nm_per_rad),
                  value_of(s, "damping_nm_s_per_rad", fallback.damping_nm_s_per_rad)};
  if (out.damping_nm_s_per_rad < 0.0) s.fail("damping_nm_s_per_rad", "must be >= 0");
  return out;
}

MotorModel motor(const YamlReader& r, const std::string& key, MotorModel fallback) {
  if (!r.has(key)) return fallback;
  const YamlReader s = r.child(key);
  s.reject_unknown_keys({"stall_torque_nm", "no_load_speed_rad_s", "kp_nm_per_rad", "kd_nm_s_per_rad",
                         "coulomb_friction_nm", "viscous_friction_nm_s_per_rad", "reflected_inertia_kg_m2"});
  MotorModel out{positive(s, "stall_torque_nm", fallback.stall_torque_nm),
                 positive(s, "no_load_speed_rad_s", fallback.no_load_speed_rad_s),
                 value_of(s, "kp_nm_per_rad", fallback.kp_nm_per_rad),
                 value_of(s, "kd_nm_s_per_rad", fallback.kd_nm_s_per_rad),
                 non_negative(s, "coulomb_friction_nm", fallback.coulomb_friction_nm),
                 non_negative(s, "viscous_friction_nm_s_per_rad", fallback.viscous_friction_nm_s_per_rad),
                 non_negative(s, "reflected_inertia_kg_m2", fallback.reflected_inertia_kg_m2)};
  return out;
}

}  // namespace

PlanarLegModel load_model_file(const std::string& path) { return parse_model_file(YamlReader::from_file(path)); }

PlanarLegModel parse_model_file(const YamlReader& r) {
  PlanarLegModel m;
  r.reject_unknown_keys({"trunk", "femur", "shank", "foot", "leg", "knee_spring", "biarticular_spring",
                         "hip_motor", "knee_motor", "contact", "foot_sensor", "simulation"});
  if (r.has("trunk")) {
    const YamlReader t = r.child("trunk");
    t.reject_unknown_keys({"mass_kg", "length_m", "hip_spacing_m", "height_m", "depth_m"});
    m.trunk_mass_kg = positive(t, "mass_kg", m.trunk_mass_kg);
    m.trunk_length_m = positive(t, "length_m", m.trunk_length_m);
    m.hip_spacing_m = positive(t, "hip_spacing_m", m.hip_spacing_m);
    m.trunk_height_m = positive(t, "height_m", m.trunk_height_m);
    m.trunk_depth_m = positive(t, "depth_m", m.trunk_depth_m);
  }
  m.femur = segment(r, "femur", m.femur);
  m.shank = segment(r, "shank", m.shank);
  m.foot = segment(r, "foot", m.foot);
  if (r.has("leg")) {
    const YamlReader l = r.child("leg");
    l.reject_unknown_keys({"toe_radius_m", "femur_mount_angle_rad", "knee_stand_flexion_rad",
                           "knee_min_flexion_rad", "knee_max_flexion_rad", "ankle_range_rad",
                           "knee_joint_friction_nm"});
    m.toe_radius_m = positive(l, "toe_radius_m", m.toe_radius_m);
    m.femur_mount_angle_rad = value_of(l, "femur_mount_angle_rad", m.femur_mount_angle_rad);
    m.knee_stand_flexion_rad = positive(l, "knee_stand_flexion_rad", m.knee_stand_flexion_rad);
    m.knee_min_flexion_rad = value_of(l, "knee_min_flexion_rad", m.knee_min_flexion_rad);
    m.knee_max_flexion_rad = positive(l, "knee_max_flexion_rad", m.knee_max_flexion_rad);
    m.ankle_range_rad = positive(l, "ankle_range_rad", m.ankle_range_rad);
    m.knee_joint_friction_nm = non_negative(l, "knee_joint_friction_nm", m.knee_joint_friction_nm);
    if (m.knee_min_flexion_rad >= m.knee_stand_flexion_rad || m.knee_stand_flexion_rad >= m.knee_max_flexion_rad) {
      l.fail("knee_stand_flexion_rad", "must lie strictly between knee_min_flexion_rad and knee_max_flexion_rad");
    }
  }
  m.knee_spring = spring(r, "knee_spring", m.knee_spring);
  m.biarticular_spring = spring(r, "biarticular_spring", m.biarticular_spring);
  m.hip_motor = motor(r, "hip_motor", m.hip_motor);
  if (r.has("knee_motor")) {
    const YamlReader k = r.child("knee_motor");
    k.reject_unknown_keys({"stall_torque_nm", "no_load_speed_rad_s", "bandwidth_per_s"});
    m.knee_motor.stall_torque_nm = positive(k, "stall_torque_nm", m.knee_motor.stall_torque_nm);
    m.knee_motor.no_load_speed_rad_s = positive(k, "no_load_speed_rad_s", m.knee_motor.no_load_speed_rad_s);
    m.knee_motor_bandwidth_per_s = positive(k, "bandwidth_per_s", m.knee_motor_bandwidth_per_s);
  }
  if (r.has("contact")) m.contact = parse_contact(r.child("contact"), m.contact);
  if (r.has("foot_sensor")) m.foot_sensor = parse_foot_sensor(r.child("foot_sensor"), m.foot_sensor);
  if (r.has("simulation")) parse_simulation(r.child("simulation"), m.physics_rate_hz, m.gravity_m_s2);
  // Finite and > 0 is not enough: 1e308 kg aborts ODE (physical_ranges.hpp).
  if (const auto problem = check_physical_ranges(m)) {
    (r.has(problem->section) ? r.child(problem->section) : r).fail(problem->key, problem->message);
  }
  return m;
}

}  // namespace cpgmatch::sim

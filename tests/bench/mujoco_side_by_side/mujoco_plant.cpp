#include "mujoco_plant.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>
#include <mujoco/mujoco.h>
#include <unistd.h>

namespace cpgmatch::bench {
namespace {

namespace fs = std::filesystem;

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

// Inserts `what` right after the opening tag that starts at `tag` (e.g. "<robot"); throws when absent.
std::string insert_after_tag(const std::string& text, const std::string& tag, const std::string& what) {
  const auto start = text.find(tag);
  if (start == std::string::npos) throw std::runtime_error("MJCF/URDF has no " + tag);
  const auto end = text.find('>', start);
  return text.substr(0, end + 1) + what + text.substr(end + 1);
}

// The ODE plant's actuator laws (workers/sim/src/ode_plant.cpp), written again here because they are
// private there; the same formulas, so that the two engines differ only in their dynamics and contact.
double available_torque(const sim::MotorModel& m, double speed) {
  return DcMotorLine{m.stall_torque_nm, m.no_load_speed_rad_s}.available_torque_nm(speed);
}
double limit_torque(double torque, double speed, const sim::MotorModel& m) {
  const bool motoring = torque * speed > 0.0;
  const double cap = motoring ? available_torque(m, speed) : m.stall_torque_nm;
  return std::clamp(torque, -cap, cap);
}
double knee_speed_limit(double pushing, double spring_k, double dt, const sim::MotorModel& m) {
  const double w0 = m.no_load_speed_rad_s, ts = m.stall_torque_nm;
  const double on_line = w0 * (1.0 - pushing / ts) / (1.0 + w0 * spring_k * dt / ts);
  const double braking = pushing < 0.0 ? -pushing / (spring_k * dt) : 0.0;
  return std::clamp(std::max(on_line, braking), 0.0, w0);
}
double dry_friction(double torque_nm, double speed_rad_s) { return -torque_nm * std::tanh(speed_rad_s / 0.05); }

}  // namespace

struct MujocoPlant::Impl {
  struct Leg {
    int hip_q, hip_v, knee_q, knee_v, ankle_q = -1, ankle_v = -1;
    int toe_geom;
    double knee_motor_flexion = 0.0, knee_motor_speed = 0.0;
    double hip_torque = 0.0, knee_torque = 0.0, normal_force = 0.0, sensed_force = 0.0;
  };

  sim::PlanarLegModel model;
  std::string mjcf;
  mjModel* m = nullptr;
  mjData* d = nullptr;
  int rail_x = 0, rail_z = 0, rail_pitch = 0;  // qpos = qvel addresses (slide and hinge joints)
  int trunk_body = 0;
  double hip_height = 0.0;
  std::vector<Leg> legs;
  PerLeg<JointCommand> commands;

  int joint(const std::string& name) const {
    const int id = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    if (id < 0) throw std::runtime_error("MuJoCo model has no joint " + name);
    return id;
  }

  Impl(const RobotDescription& robot, const sim::PlanarLegModel& mm, const MujocoSolver& solver) : model(mm) {
    // Where the ODE plant starts its trunk: the standing pose with the toes 1 mm above the ground.
    const double a0 = model.femur_mount_angle_rad, b0 = model.knee_stand_flexion_rad;
    const double leg_drop = model.femur.length_m * std::cos(a0) + model.shank.length_m * std::cos(a0 - b0) +
                            (model.has_ankle ? model.foot.length_m * std::cos(a0) : 0.0);
    hip_height = leg_drop + model.toe_radius_m + 0.001;

    // 1. MuJoCo's own URDF import. fusestatic="false": otherwise the root link, having no joint to the
    // world, is fused into the world body and the trunk is welded in place.
    const fs::path dir = fs::temp_directory_path();
    const std::string stem = fmt::format("cpgmatch-mujoco-{}", ::getpid());
    const fs::path urdf_path = dir / (stem + ".urdf"), mjcf_path = dir / (stem + ".xml");
    write_text(urdf_path, insert_after_tag(robot.urdf_text, "<robot",
                                           "\n<mujoco><compiler fusestatic=\"false\" discardvisual=\"true\"/></mujoco>"));
    char error[1000] = "";
    mjModel* imported = mj_loadXML(urdf_path.c_str(), nullptr, error, sizeof error);
    if (imported == nullptr) throw std::runtime_error(std::string("MuJoCo cannot load the URDF: ") + error);
    if (mj_saveLastXML(mjcf_path.c_str(), imported, error, sizeof error) == 0) {
      throw std::runtime_error(std::string("MuJoCo cannot export the URDF as MJCF: ") + error);
    }
    mj_deleteModel(imported);

    // 2. The rail (the paper's planar boom): the trunk slides forward and up and pitches, as the ODE plant's
    // Plane2D joint allows; the floor; the physics rate and gravity of the robot description.
    std::string text = read_text(mjcf_path);
    const std::string trunk_tag = "<body name=\"" + robot.root_link + "\"";
    const auto at = text.find(trunk_tag);
    if (at == std::string::npos) throw std::runtime_error("MJCF has no body " + robot.root_link);
    const auto close = text.find('>', at);
    text = text.substr(0, at) +
           fmt::format("<body name=\"{}\" pos=\"0 0 {:.9f}\">\n"
                       "<joint name=\"rail_x\" type=\"slide\" axis=\"1 0 0\" pos=\"0 0 0\"/>\n"
                       "<joint name=\"rail_z\" type=\"slide\" axis=\"0 0 1\" pos=\"0 0 0\"/>\n"
                       "<joint name=\"rail_pitch\" type=\"hinge\" axis=\"0 -1 0\" pos=\"0 0 0\"/>\n",
                       robot.root_link, hip_height) +
           text.substr(close + 1);
    text = insert_after_tag(text, "<worldbody", "\n<geom name=\"floor\" type=\"plane\" size=\"0 0 1\"/>");
    text = insert_after_tag(text, "<compiler",
                            fmt::format("\n<option timestep=\"{:.9g}\" gravity=\"0 0 {:.9g}\"/>",
                                        1.0 / model.physics_rate_hz, -model.gravity_m_s2));
    mjcf = text;
    write_text(mjcf_path, text);
    m = mj_loadXML(mjcf_path.c_str(), nullptr, error, sizeof error);
    fs::remove(urdf_path);
    fs::remove(mjcf_path);
    if (m == nullptr) throw std::runtime_error(std::string("MuJoCo cannot load the planar MJCF: ") + error);

    // 3. What the URDF cannot say, from robot.yaml as the ODE plant has it.
    rail_x = m->jnt_qposadr[joint("rail_x")];
    rail_z = m->jnt_qposadr[joint("rail_z")];
    rail_pitch = m->jnt_qposadr[joint("rail_pitch")];
    trunk_body = mj_name2id(m, mjOBJ_BODY, robot.root_link.c_str());
    // Only the toes touch the floor, as in the ODE plant (its trunk and segments have no geometry).
    for (int g = 0; g < m->ngeom; ++g) {
      m->geom_contype[g] = 0;
      m->geom_conaffinity[g] = 0;
    }
    const int floor = mj_name2id(m, mjOBJ_GEOM, "floor");
    m->geom_conaffinity[floor] = 1;
    // Contact: a spring-damper per unit mass (MuJoCo's negative solref) for a foot's share of the body,
    // which is what the ODE plant's stiffness and damping were chosen for (robot.yaml: "critically damped
    // for a foot's ~1 kg share"); impedance held near 1 so the reference acceleration is what the solver
    // delivers.
    const double share = model.total_mass_kg() / static_cast<double>(model.leg_count());
    std::vector<int> contact_geoms{floor};
    for (const auto& leg_desc : robot.legs) {
      Leg leg;
      const int hip = joint(leg_desc.hip_joint), knee = joint(leg_desc.knee_joint);
      leg.hip_q = m->jnt_qposadr[hip];
      leg.hip_v = m->jnt_dofadr[hip];
      leg.knee_q = m->jnt_qposadr[knee];
      leg.knee_v = m->jnt_dofadr[knee];
      if (!leg_desc.ankle_joint.empty()) {
        const int ankle = joint(leg_desc.ankle_joint);
        leg.ankle_q = m->jnt_qposadr[ankle];
        leg.ankle_v = m->jnt_dofadr[ankle];
      }
      // The hip motor's reflected inertia: MuJoCo's armature is exactly a rotor's inertia seen at the joint.
      m->dof_armature[leg.hip_v] = model.hip_motor.reflected_inertia_kg_m2;
      const int foot = mj_name2id(m, mjOBJ_BODY, leg_desc.foot_link.c_str());
      leg.toe_geom = -1;
      for (int g = 0; g < m->ngeom; ++g) {
        if (m->geom_bodyid[g] == foot && m->geom_type[g] == mjGEOM_SPHERE) leg.toe_geom = g;
      }
      if (leg.toe_geom < 0) throw std::runtime_error("no toe sphere on " + leg_desc.foot_link);
      m->geom_contype[leg.toe_geom] = 1;
      contact_geoms.push_back(leg.toe_geom);
      leg.knee_motor_flexion = b0;
      legs.push_back(leg);
    }
    for (int g : contact_geoms) {
      m->geom_condim[g] = 3;
      m->geom_friction[3 * g] = model.contact.friction;
      m->geom_solref[mjNREF * g + 0] = -model.contact.stiffness_n_per_m / share;
      m->geom_solref[mjNREF * g + 1] = -model.contact.damping_n_s_per_m / share;
      const double imp[mjNIMP] = {0.99, 0.99, 0.001, 0.5, 2.0};
      std::copy(imp, imp + mjNIMP, &m->geom_solimp[mjNIMP * g]);
    }
    if (solver.solver == "newton") m->opt.solver = mjSOL_NEWTON;
    else if (solver.solver == "cg") m->opt.solver = mjSOL_CG;
    else if (solver.solver == "pgs") m->opt.solver = mjSOL_PGS;
    else throw std::runtime_error("solver '" + solver.solver + "': expected newton, cg or pgs");
    m->opt.iterations = solver.iterations;
    d = mj_makeData(m);
    mj_forward(m, d);
    commands = PerLeg<JointCommand>(legs.size());
  }

  ~Impl() {
    if (d) mj_deleteData(d);
    if (m) mj_deleteModel(m);
  }

  // Generalised forces in MuJoCo's joint coordinates: hip + = foot forward (the ODE plant's hip angle),
  // knee + = flexion (minus the ODE plant's knee angle), ankle as the URDF's axis -y (the ODE ankle angle).
  void apply_actuators() {
    const double dt = m->opt.timestep;
    const double b0 = model.knee_stand_flexion_rad;
    mju_zero(d->qfrc_applied, m->nv);
    for (std::size_t i = 0; i < legs.size(); ++i) {
      Leg& leg = legs[i];
      const JointCommand& cmd = commands[i];
      const double q = d->qpos[leg.hip_q], qd = d->qvel[leg.hip_v];
      double tau_hip = 0.0;
      if (!cmd.hip_passive) {
        const auto& hm = model.hip_motor;
        tau_hip = limit_torque(hm.kp_nm_per_rad * (cmd.hip_angle_rad - q) - hm.kd_nm_s_per_rad * qd, qd, hm);
      }
      const double drag = -model.hip_motor.viscous_friction_nm_s_per_rad * qd +
                          dry_friction(model.hip_motor.coulomb_friction_nm, qd);
      d->qfrc_applied[leg.hip_v] += tau_hip + drag;
      leg.hip_torque = tau_hip;

      const double beta = b0 + d->qpos[leg.knee_q];
      const double beta_rate = d->qvel[leg.knee_v];
      const auto& km = model.knee_motor;
      const double parallel = -model.knee_parallel_spring.stiffness_nm_per_rad * (beta - b0) -
                              model.knee_parallel_spring.damping_nm_s_per_rad * beta_rate;
      // The series-elastic knee (Morti's only knee drive; the bench refuses others in main.cpp).
      const double k = model.knee_spring.stiffness_nm_per_rad;
      const double target = b0 + cmd.knee_flexion_rad;
      double speed = model.knee_motor_bandwidth_per_s * (target - leg.knee_motor_flexion);
      const double held = k * (leg.knee_motor_flexion - beta);
      const double pushing = speed >= 0.0 ? held : -held;
      const double limit = knee_speed_limit(pushing, k, dt, km);
      speed = std::clamp(speed, -limit, limit);
      const double before = leg.knee_motor_flexion;
      leg.knee_motor_flexion += speed * dt;
      const double max_deflection = km.stall_torque_nm / k;
      leg.knee_motor_flexion = std::clamp(leg.knee_motor_flexion, beta - max_deflection, beta + max_deflection);
      leg.knee_motor_speed = (leg.knee_motor_flexion - before) / dt;
      const double spring_torque = k * (leg.knee_motor_flexion - beta);
      const double flex_torque = spring_torque - model.knee_spring.damping_nm_s_per_rad * beta_rate;
      d->qfrc_applied[leg.knee_v] += flex_torque + parallel + dry_friction(model.knee_joint_friction_nm, beta_rate);
      leg.knee_torque = spring_torque;

      if (leg.ankle_q >= 0) {
        // Biarticular spring: foot parallel to the femur. Its deviation in ODE angles is knee + ankle,
        // here -q_knee + q_ankle; the torque pair on foot and femur is a generalised force on both joints.
        const double deviation = -d->qpos[leg.knee_q] + d->qpos[leg.ankle_q];
        const double deviation_rate = -d->qvel[leg.knee_v] + d->qvel[leg.ankle_v];
        const double tau_b = -model.biarticular_spring.stiffness_nm_per_rad * deviation -
                             model.biarticular_spring.damping_nm_s_per_rad * deviation_rate;
        d->qfrc_applied[leg.knee_v] -= tau_b;
        d->qfrc_applied[leg.ankle_v] += tau_b;
      }
    }
  }

  void read_contact_forces() {
    for (auto& leg : legs) leg.normal_force = 0.0;
    for (int c = 0; c < d->ncon; ++c) {
      const mjContact& con = d->contact[c];
      for (auto& leg : legs) {
        if (con.geom1 != leg.toe_geom && con.geom2 != leg.toe_geom) continue;
        mjtNum f[6];
        mj_contactForce(m, d, c, f);
        leg.normal_force += std::max(0.0, static_cast<double>(f[0]));
      }
    }
    const double dt = m->opt.timestep, tau = model.foot_sensor.time_constant_s;
    const double blend = dt / (tau + dt);
    for (auto& leg : legs) leg.sensed_force += blend * (model.foot_sensor.sensitivity * leg.normal_force - leg.sensed_force);
  }

  void step() {
    apply_actuators();
    mj_step(m, d);
    read_contact_forces();
  }
};

MujocoPlant::MujocoPlant(const RobotDescription& robot, const sim::PlanarLegModel& model, const MujocoSolver& solver)
    : impl_(std::make_unique<Impl>(robot, model, solver)) {}
MujocoPlant::~MujocoPlant() = default;

void MujocoPlant::command(const PerLeg<JointCommand>& commands) { impl_->commands = commands; }

void MujocoPlant::advance(double dt_s) {
  const long steps = std::max(1L, std::lround(dt_s / impl_->m->opt.timestep));
  for (long i = 0; i < steps; ++i) impl_->step();
}

double MujocoPlant::time_step_s() const { return impl_->m->opt.timestep; }

std::optional<EnergyModel> MujocoPlant::energy_model() const {
  const auto& mm = impl_->model;
  return EnergyModel{{mm.hip_motor.stall_torque_nm, mm.hip_motor.no_load_speed_rad_s},
                     {mm.knee_motor.stall_torque_nm, mm.knee_motor.no_load_speed_rad_s}, mm.total_mass_kg(),
                     mm.gravity_m_s2};
}

const std::string& MujocoPlant::mjcf() const { return impl_->mjcf; }

PlantState MujocoPlant::state() const {
  const Impl& p = *impl_;
  PlantState s;
  s.time_s = p.d->time;
  s.trunk.x_m = p.d->qpos[p.rail_x];
  s.trunk.vx_mps = p.d->qvel[p.rail_x];
  s.trunk.height_m = p.d->xpos[3 * p.trunk_body + 2];
  s.trunk.pitch_rad = p.d->qpos[p.rail_pitch];
  s.legs = PerLeg<LegState>(p.legs.size());
  for (std::size_t i = 0; i < p.legs.size(); ++i) {
    const auto& leg = p.legs[i];
    s.legs[i].hip_angle_rad = p.d->qpos[leg.hip_q];
    s.legs[i].knee_flexion_rad = p.d->qpos[leg.knee_q];
    s.legs[i].hip_torque_nm = leg.hip_torque;
    s.legs[i].knee_torque_nm = leg.knee_torque;
    s.legs[i].hip_speed_rad_s = p.d->qvel[leg.hip_v];
    s.legs[i].knee_motor_speed_rad_s = leg.knee_motor_speed;
    s.legs[i].foot_normal_force_n = leg.sensed_force;
  }
  return s;
}

}  // namespace cpgmatch::bench

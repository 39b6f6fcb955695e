#include "cpgmatch/sim/ode_plant.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include <ode/ode.h>

#include "cpgmatch/sim/ode_errors.hpp"

namespace cpgmatch::sim {
namespace {

void init_ode_once() {
  static std::once_flag flag;
  std::call_once(flag, [] {
    install_ode_error_handlers();  // an ODE assertion ends the rollout with its reason, not SIGABRT
    dInitODE2(0);
  });
  dAllocateODEDataForThread(dAllocateMaskAll);
}

// Direction of a segment at absolute angle a (radians from straight down, + forward/CCW).
struct Vec2 {
  double x, y;
};
Vec2 direction(double a) { return {std::sin(a), -std::cos(a)}; }

// A body's rotation about z (radians), which the joints read some 50 times per physics step: it is computed
// from the quaternion once per step (remember_angle_z, after every projection onto the plane) into a slot
// that the body's user data points to, since atan2 alone was 5% of a rollout. The same bits as computing it
// at each read.
double body_angle_z(dBodyID body) { return *static_cast<const double*>(dBodyGetData(body)); }

void remember_angle_z(dBodyID body) {
  const dReal* q = dBodyGetQuaternion(body);
  *static_cast<double*>(dBodyGetData(body)) = 2.0 * std::atan2(q[3], q[0]);
}

// Wraps an angle into (-pi, pi] (std::remainder's value; inside (-pi, pi) that is the angle itself, which
// skips the call for almost every joint angle).
double wrap_angle(double a) {
  if (std::abs(a) < std::numbers::pi) return a;
  return std::remainder(a, 2.0 * std::numbers::pi);
}

// A leg joint: a revolute joint whose axis is the plane's normal (world z), in one of two builds.
//
// Planar (a robot on a rail or boom): two constraint rows, the two in-plane components of "the anchor of
// body b stays on body a", plus, where the joint has end stops, a one-axis angular motor that adds a row
// only while a stop is reached. ODE has no two-row pin, so the rows are two of its distance joints (DBall):
// body b's anchor P keeps its distance kPinArm_m from the points P + kPinArm_m x and P + kPinArm_m y fixed on
// body a. Their rows are unit vectors along those two perpendicular arms, rotating with body a: they span
// the plane, so they constrain exactly the in-plane motion of P that a pin does, and the constraint force is
// the pin's (only its position-drift correction acts along the arms instead of along x and y; the other
// intersection of the two circles lies kPinArm_m sqrt(2) away, far beyond any drift).
// Why not more rows: dWorldStep's dense solver costs O(rows^3). An ODE hinge (5 rows) spent ~65% of a
// rollout in the LDLT factorisation of 63 joint rows (until 2026-12-02); a ball joint (3 rows, until
// 2026-12-07) adds an out-of-plane row per joint that, like the hinge's two out-of-plane rotation rows,
// only repeats what planarity gives. Planarity is kept instead by projecting every body onto the plane
// after each step (OdePlant::Impl::project_onto_plane), as ODE's own Plane2D demo does; every force in the
// model lies in the plane, so the projection only removes round-off.
//
// Free (a robot standing on its own, free in 3D): an ODE hinge, whose five rows are all needed now, since
// the feet push sideways and the trunk rolls: the out-of-plane rows carry real load. Its angle is read from
// the two bodies' rotations (relative_angle), not from the hinge's own angle, so that both builds share the
// angle, rate, torque and stop code below and its conventions.
//
// Conventions are the hinge's that cpgmatch used before: the angle is body b's counter-clockwise rotation
// relative to body a about the axis (+z in the pose the joint was made in), zero in that pose; a positive
// torque turns b counter-clockwise relative to a.
class LegJoint {
 public:
  enum class Build { kPlanar, kFree };

  LegJoint() = default;
  LegJoint(dWorldID world, dBodyID a, dBodyID b, double anchor_x, double anchor_y, double anchor_z, Build build)
      : a_(a), b_(b), free_(build == Build::kFree) {
    if (free_) {
      pin_[0] = dJointCreateHinge(world, nullptr);
      dJointAttach(pin_[0], a, b);
      dJointSetHingeAnchor(pin_[0], anchor_x, anchor_y, anchor_z);
      dJointSetHingeAxis(pin_[0], 0.0, 0.0, 1.0);
    } else {
      const double arm_x[2] = {kPinArm_m, 0.0}, arm_y[2] = {0.0, kPinArm_m};
      for (int k = 0; k < 2; ++k) {
        pin_[k] = dJointCreateDBall(world, nullptr);
        dJointAttach(pin_[k], a, b);
        dJointSetDBallAnchor1(pin_[k], anchor_x + arm_x[k], anchor_y + arm_y[k], anchor_z);
        dJointSetDBallAnchor2(pin_[k], anchor_x, anchor_y, anchor_z);
        dJointSetDBallDistance(pin_[k], kPinArm_m);
      }
    }
    dBodyGetPosRelPoint(a, anchor_x, anchor_y, anchor_z, anchor_on_a_);
    zero_ = relative_angle();
  }

  // End stops (radians, in this joint's angle): a user-mode angular motor about -z of body a, which ODE
  // constrains exactly as a hinge's stops (same limit code, same ERP/CFM defaults).
  void set_stops(dWorldID world, double lo, double hi) {
    stops_ = dJointCreateAMotor(world, nullptr);
    dJointAttach(stops_, a_, b_);
    dJointSetAMotorMode(stops_, dAMotorUser);
    dJointSetAMotorNumAxes(stops_, 1);
    dJointSetAMotorAxis(stops_, 0, 1, 0, 0, -1);  // relative to body a, -z: the motor's rate is rate()
    dJointSetAMotorParam(stops_, dParamLoStop, lo);
    dJointSetAMotorParam(stops_, dParamHiStop, hi);
    dJointSetAMotorAngle(stops_, 0, angle());
  }

  double angle() const { return wrap_angle(relative_angle() - zero_); }
  double rate() const {
    const dReal* wa = dBodyGetAngularVel(a_);
    const dReal* wb = dBodyGetAngularVel(b_);
    if (!free_) return wb[2] - wa[2];
    const Axis n = axis();
    return (wb[0] - wa[0]) * n.x + (wb[1] - wa[1]) * n.y + (wb[2] - wa[2]) * n.z;
  }

  // The joint's axis in the world: body a's z axis (z itself in the plane).
  struct Axis {
    double x, y, z;
  };
  Axis axis() const {
    if (!free_) return {0.0, 0.0, 1.0};
    const dReal* r = dBodyGetRotation(a_);  // row-major 3x4: column 2 is body a's z axis in the world
    return {r[2], r[6], r[10]};
  }

  void add_torque(double torque) const {
    if (!free_) {
      dBodyAddTorque(a_, 0, 0, -torque);
      dBodyAddTorque(b_, 0, 0, torque);
      return;
    }
    const Axis n = axis();
    dBodyAddTorque(a_, -torque * n.x, -torque * n.y, -torque * n.z);
    dBodyAddTorque(b_, torque * n.x, torque * n.y, torque * n.z);
  }

  // How far apart the joint's two halves are (metres): its anchor as fixed on body a and as fixed on body b.
  // The solver's drift: some tens of micrometres on a sound joint (tests/physics: < 60 um walking or falling).
  double gap_m() const {
    dVector3 on_a, on_b;
    dBodyGetRelPointPos(a_, anchor_on_a_[0], anchor_on_a_[1], anchor_on_a_[2], on_a);
    if (free_) {
      dJointGetHingeAnchor2(pin_[0], on_b);
    } else {
      dJointGetDBallAnchor2(pin_[0], on_b);
    }
    return std::sqrt((on_a[0] - on_b[0]) * (on_a[0] - on_b[0]) + (on_a[1] - on_b[1]) * (on_a[1] - on_b[1]) +
                     (on_a[2] - on_b[2]) * (on_a[2] - on_b[2]));
  }

  // A user-mode motor knows its angle only from us: called before every step.
  void update_stops() const {
    if (stops_ != nullptr) dJointSetAMotorAngle(stops_, 0, angle());
  }

 private:
  double relative_angle() const {
    if (!free_) return body_angle_z(b_) - body_angle_z(a_);
    // b's rotation relative to a, R_a^T R_b, is a rotation about z (the hinge holds the other two): its
    // angle is atan2 of that matrix's (1, 0) and (0, 0) entries.
    const dReal* ra = dBodyGetRotation(a_);
    const dReal* rb = dBodyGetRotation(b_);
    auto entry = [&](int i, int j) {  // (R_a^T R_b)(i, j) = column i of R_a . column j of R_b
      return ra[i] * rb[j] + ra[4 + i] * rb[4 + j] + ra[8 + i] * rb[8 + j];
    };
    return std::atan2(entry(1, 0), entry(0, 0));
  }

  dBodyID a_ = nullptr, b_ = nullptr;
  bool free_ = false;
  // Long against any drift of the anchor (tens of micrometres), short against the bodies (a few centimetres): the
  // rows' conditioning does not depend on it.
  static constexpr double kPinArm_m = 0.05;
  dJointID pin_[2] = {nullptr, nullptr};  // planar: the two distance joints; free: the hinge in pin_[0]
  dVector3 anchor_on_a_{};  // the anchor in body a's frame
  dJointID stops_ = nullptr;
  double zero_ = 0.0;
};

DcMotorLine line_of(const MotorModel& m) { return {m.stall_torque_nm, m.no_load_speed_rad_s}; }

// Torque a motor can give at joint speed w: the stall torque, falling linearly to zero at the no-load
// speed when the motor is driving in the direction of motion (a DC motor's torque-speed line).
double limit_torque(double torque, double speed, const MotorModel& m) {
  const bool motoring = torque * speed > 0.0;
  const double cap = motoring ? line_of(m).available_torque_nm(speed) : m.stall_torque_nm;
  return std::clamp(torque, -cap, cap);
}

// The knee motor is position-controlled through the series spring: it chooses a speed, and the spring
// decides its torque. The same torque-speed line as the hip's (the same motor) bounds that speed while it
// is motoring. `pushing`: the torque the motor holds against the spring, taken along the motion (> 0:
// motoring). Moving at w for one step dt changes that torque by k w dt, and the pair (torque after the
// step, w) must lie under the line: w <= w0 (1 - (pushing + k w dt) / ts), i.e.
// w <= w0 (1 - pushing / ts) / (1 + w0 k dt / ts): the explicit step stays exactly on or under the line.
// A motor pulled along by the spring (pushing < 0) is braking until the torque changes sign, which takes
// |pushing| / (k dt) of speed; up to the no-load speed either way.
double knee_speed_limit(double pushing, double spring_k, double dt, const MotorModel& m) {
  const double w0 = m.no_load_speed_rad_s, ts = m.stall_torque_nm;
  const double on_line = w0 * (1.0 - pushing / ts) / (1.0 + w0 * spring_k * dt / ts);
  const double braking = pushing < 0.0 ? -pushing / (spring_k * dt) : 0.0;
  return std::clamp(std::max(on_line, braking), 0.0, w0);
}

// Dry (Coulomb) friction of a joint turning at `speed`, regularised below kFrictionSpeedScale so that it is
// smooth. Why explicit and smooth rather than ODE's zero-velocity joint motor with a force limit (which
// holds a joint exactly at rest): every such motor adds a constraint row to dWorldStep's dense solver, and
// eight of them nearly doubled the rollout time (0.45 -> 0.8 s). The price is creep below 0.05 rad/s.
// Stability: the slope torque/scale acts as a damper, at most 0.2 / 0.05 = 4 N m s/rad on the hip
// (c h / I = 0.45 with the reflected inertia) and 0.4 N m s/rad on the knee (c h / I ~ 0.4): both < 1.
constexpr double kFrictionSpeedScale = 0.05;  // rad/s
double dry_friction(double torque_nm, double speed_rad_s) {
  return -torque_nm * std::tanh(speed_rad_s / kFrictionSpeedScale);
}

constexpr int kMaxContactsPerToe = 3;

// Collects up to kMaxContactsPerToe contacts of one toe with whatever terrain geoms the space reports.
struct ToeContacts {
  dGeomID toe;
  dContactGeom* geoms;
  int count;

  static void near_callback(void* data, dGeomID a, dGeomID b) {
    auto* self = static_cast<ToeContacts*>(data);
    if (self->count >= kMaxContactsPerToe) return;
    const dGeomID ground = a == self->toe ? b : a;
    // Toe first, so every normal points into the foot.
    self->count += dCollide(self->toe, ground, kMaxContactsPerToe - self->count, &self->geoms[self->count],
                            sizeof(dContactGeom));
  }
};

}  // namespace

struct OdePlant::Impl {
  struct LegBodies {
    dBodyID femur, shank, foot;  // foot: nullptr for a two-segment leg (the toe is on the shank)
    dBodyID toe_body;
    LegJoint hip, knee, ankle;
    dGeomID toe;
    double knee_motor_flexion = 0.0;  // absolute flexion of the knee motor's output (spring rest)
    double knee_motor_speed = 0.0;    // its rate over the last step, rad/s (+ flexing)
    double hip_torque = 0.0;
    double knee_torque = 0.0;
    double normal_force = 0.0;
    double sensed_force = 0.0;  // what the FootTile reports (PlanarLegModel::foot_sensor)
  };

  PlanarLegModel model;
  TerrainSpec terrain;
  dWorldID world = nullptr;
  dSpaceID terrain_space = nullptr;
  dJointGroupID contact_group = nullptr;
  dGeomID moving_ground = nullptr;  // the plane of a kShift terrain
  bool shifted = false;
  dBodyID trunk = nullptr;
  // Each body's angle slot (body_angle_z): the trunk and up to three segments per leg.
  std::array<double, 1 + 3 * kMaxLegs> body_angles{};
  std::size_t body_angles_used = 0;
  std::vector<LegBodies> legs;
  PerLeg<JointCommand> commands;
  std::vector<dJointFeedback> contact_feedback;
  struct ActiveContact {
    int leg;
    double normal[3];
  };
  std::vector<ActiveContact> contacts_this_step;
  dThreadingImplementationID stepping = nullptr;  // this world's own step scheduler (see the constructor)
  double time = 0.0;
  double dt = 0.001;
  double belt_travel = 0.0;  // metres the treadmill belt has moved backwards

  double belt_speed() const {
    const double ramp = terrain.treadmill_ramp_s > 0.0 ? std::min(1.0, time / terrain.treadmill_ramp_s) : 1.0;
    return terrain.treadmill_speed_mps * ramp;
  }

  Impl(const PlanarLegModel& m, const TerrainSpec& t, std::uint64_t seed) : model(m), terrain(t) {
    init_ode_once();
    dt = 1.0 / model.physics_rate_hz;
    world = dWorldCreate();
    // Each world steps with its own (self-threaded, i.e. single-threaded) job scheduler. Without one, every
    // world shares ODE's process-wide default scheduler, and two worlds stepped at once on two threads corrupt
    // its job list (ODE INTERNAL ERROR in ReleaseAJob; tests/physics/test_parallel_worlds.cpp). The
    // scheduler only orders the same work, so what a step computes is unchanged.
    stepping = dThreadingAllocateSelfThreadedImplementation();
    dWorldSetStepThreadingImplementation(world, dThreadingImplementationGetFunctions(stepping), stepping);
    dWorldSetGravity(world, 0, -model.gravity_m_s2, 0);
    dWorldSetERP(world, 0.2);
    dWorldSetCFM(world, 1e-9);
    dWorldSetContactSurfaceLayer(world, 0.0002);
    contact_group = dJointGroupCreate(0);
    terrain_space = dHashSpaceCreate(nullptr);
    build_terrain(seed);
    build_robot();
    commands = PerLeg<JointCommand>(legs.size());
    contact_feedback.resize(legs.size() * kMaxContactsPerToe);
  }

  ~Impl() {
    dJointGroupDestroy(contact_group);
    dSpaceDestroy(terrain_space);  // destroys the terrain geoms it holds
    for (auto& leg : legs) dGeomDestroy(leg.toe);
    dWorldDestroy(world);
    dThreadingFreeImplementation(stepping);
  }

  void add_static_box(double x_min, double x_max, double top_y, double bottom_y) {
    // 2 m across: wide enough for a rail's plane; a free robot may wander sideways or turn, so its ground
    // is as wide as it is long.
    const double across_m = model.planar ? 2.0 : 400.0;
    dGeomID box = dCreateBox(terrain_space, x_max - x_min, top_y - bottom_y, across_m);
    dGeomSetPosition(box, 0.5 * (x_min + x_max), 0.5 * (top_y + bottom_y), 0.0);
  }

  void build_terrain(std::uint64_t seed) {
    switch (terrain.kind) {
      case TerrainSpec::Kind::kFlat:
        dCreatePlane(terrain_space, 0, 1, 0, 0);
        break;
      case TerrainSpec::Kind::kShift:
        moving_ground = dCreatePlane(terrain_space, 0, 1, 0, 0);
        break;
      case TerrainSpec::Kind::kStep: {
        const double h = terrain.step_height_m;
        const double edge = terrain.step_distance_m;
        if (h >= 0.0) {
          dCreatePlane(terrain_space, 0, 1, 0, 0);
          add_static_box(edge, edge + 200.0, h, -1.0);
        } else {
          dCreatePlane(terrain_space, 0, 1, 0, h);
          add_static_box(-200.0, edge, 0.0, h - 1.0);
        }
        break;
      }
      case TerrainSpec::Kind::kRough: {
        dCreatePlane(terrain_space, 0, 1, 0, 0);
        std::mt19937_64 rng(seed ^ 0x5eedULL);
        std::uniform_real_distribution<double> height(0.0, terrain.rough_amplitude_m);
        const double tile = terrain.rough_tile_length_m;
        for (double x = terrain.rough_start_m; x < terrain.rough_start_m + 40.0; x += tile) {
          const double h = height(rng);
          if (h > 1e-4) add_static_box(x, x + tile, h, -0.5);
        }
        break;
      }
    }
  }

  void give_angle_slot(dBodyID body) {
    dBodySetData(body, &body_angles.at(body_angles_used++));
    remember_angle_z(body);
  }

  // z: the segment's sideways place (world z, + right; 0 for every leg of a planar robot).
  dBodyID make_segment(Vec2 start, double z, double angle, const SegmentModel& seg) {
    dBodyID body = dBodyCreate(world);
    const Vec2 d = direction(angle);
    dBodySetPosition(body, start.x + 0.5 * seg.length_m * d.x, start.y + 0.5 * seg.length_m * d.y, z);
    dMatrix3 R;
    dRFromAxisAndAngle(R, 0, 0, 1, angle);
    dBodySetRotation(body, R);
    give_angle_slot(body);
    // A slender bar along the body's local -y axis.
    dMass mass;
    dMassSetBoxTotal(&mass, seg.mass_kg, 0.02, seg.length_m, 0.02);
    dBodySetMass(body, &mass);
    return body;
  }

  // The hip motor's rotor turns N times faster than the leg, so the leg feels N^2 times its inertia.
  // Added to the femur's own pitch inertia: exact for the leg swinging relative to a still trunk, and
  // the trunk's own rotation (N times slower than the rotor's) is a small correction we neglect.
  static void add_reflected_inertia(dBodyID femur, double inertia_kg_m2) {
    if (inertia_kg_m2 <= 0.0) return;
    dMass mass;
    dBodyGetMass(femur, &mass);
    mass.I[2 * 4 + 2] += inertia_kg_m2;
    dBodySetMass(femur, &mass);
  }

  // Angles: body b's counter-clockwise rotation relative to body a, the convention used everywhere in
  // cpgmatch (hip angle + = foot forward).
  LegJoint make_joint(dBodyID a, dBodyID b, Vec2 anchor, double z) {
    return LegJoint(world, a, b, anchor.x, anchor.y, z, model.planar ? LegJoint::Build::kPlanar : LegJoint::Build::kFree);
  }

  void build_robot() {
    const double a0 = model.femur_mount_angle_rad;
    const double b0 = model.knee_stand_flexion_rad;
    const Vec2 df = direction(a0), ds = direction(a0 - b0), dp = direction(a0);
    const double foot_drop = model.has_ankle ? model.foot.length_m * dp.y : 0.0;
    const double leg_drop = -(model.femur.length_m * df.y + model.shank.length_m * ds.y + foot_drop);
    const double hip_height = leg_drop + model.toe_radius_m + 0.001;

    trunk = dBodyCreate(world);
    dBodySetPosition(trunk, 0.0, hip_height, 0.0);
    dMass tm;
    dMassSetBoxTotal(&tm, model.trunk_mass_kg, model.trunk_length_m, model.trunk_height_m, model.trunk_depth_m);
    dBodySetMass(trunk, &tm);
    give_angle_slot(trunk);
    // The rail (forward, up, pitch) needs no joint: the projection onto the plane after every step keeps the
    // trunk in it, as it keeps the legs (a Plane2D joint's three rows only repeated that; until 2026-12-07).
    // A free robot's trunk has no constraint at all: its legs alone hold it up.

    const std::vector<double> hip_x = model.hip_positions_m();
    legs.resize(hip_x.size());
    for (std::size_t i = 0; i < legs.size(); ++i) {
      auto& leg = legs[i];
      // A free robot's legs stand at their sides: the description's + left is the world's -z (x forward,
      // y up, z = x cross y to the right).
      const double z = model.planar ? 0.0 : -model.hip_lateral_m.at(i);
      const Vec2 hip{hip_x[i], hip_height};
      const Vec2 knee{hip.x + model.femur.length_m * df.x, hip.y + model.femur.length_m * df.y};
      const Vec2 ankle{knee.x + model.shank.length_m * ds.x, knee.y + model.shank.length_m * ds.y};
      leg.femur = make_segment(hip, z, a0, model.femur);
      add_reflected_inertia(leg.femur, model.hip_motor.reflected_inertia_kg_m2);
      leg.shank = make_segment(knee, z, a0 - b0, model.shank);
      // A knee motor that drives the knee directly turns with it: its rotor's inertia loads the shank.
      if (model.knee_drive == PlanarLegModel::KneeDrive::kPositionPd) add_reflected_inertia(leg.shank, model.knee_motor.reflected_inertia_kg_m2);
      leg.foot = model.has_ankle ? make_segment(ankle, z, a0, model.foot) : nullptr;
      // Joints in the order hip, knee, ankle, then the stop motors: ODE solves its rows in creation order,
      // and this is the order every earlier release used (the same bits for Morti).
      leg.hip = make_joint(trunk, leg.femur, hip, z);
      leg.knee = make_joint(leg.femur, leg.shank, knee, z);
      if (model.has_ankle) leg.ankle = make_joint(leg.shank, leg.foot, ankle, z);
      // Knee angle = -(flexion - b0): stops keep the flexion inside its mechanical range.
      leg.knee.set_stops(world, b0 - model.knee_max_flexion_rad, b0 - model.knee_min_flexion_rad);
      leg.toe = dCreateSphere(nullptr, model.toe_radius_m);
      if (model.has_ankle) {
        // The parallel mechanism's end stops: the foot turns at most ankle_range_rad either way from its
        // standing pose relative to the shank.
        leg.ankle.set_stops(world, -model.ankle_range_rad, model.ankle_range_rad);
        leg.toe_body = leg.foot;
        dGeomSetBody(leg.toe, leg.foot);
        dGeomSetOffsetPosition(leg.toe, 0.0, -0.5 * model.foot.length_m, 0.0);
      } else {
        leg.toe_body = leg.shank;  // a two-segment leg: the toe at the shank's end
        dGeomSetBody(leg.toe, leg.shank);
        dGeomSetOffsetPosition(leg.toe, 0.0, -0.5 * model.shank.length_m, 0.0);
      }
      leg.knee_motor_flexion = b0;
    }
  }

  double knee_flexion(const LegBodies& leg) const {
    return model.knee_stand_flexion_rad - leg.knee.angle();
  }

  void apply_actuators() {
    for (std::size_t i = 0; i < legs.size(); ++i) {
      auto& leg = legs[i];
      const JointCommand& cmd = commands[i];

      // Hip: PD position controller within the motor's torque-speed envelope.
      const double q = leg.hip.angle();
      const double qd = leg.hip.rate();
      double tau_hip = 0.0;
      if (!cmd.hip_passive) {
        const auto& m = model.hip_motor;
        tau_hip = limit_torque(m.kp_nm_per_rad * (cmd.hip_angle_rad - q) - m.kd_nm_s_per_rad * qd, qd, m);
      }
      // Viscous gearbox drag acts whether the motor drives or is back-driven (passive hip).
      const double drag = -model.hip_motor.viscous_friction_nm_s_per_rad * qd +
                          dry_friction(model.hip_motor.coulomb_friction_nm, qd);
      leg.hip.add_torque(tau_hip + drag);
      leg.hip_torque = tau_hip;

      const double beta = knee_flexion(leg);
      const double beta_rate = -leg.knee.rate();
      const auto& km = model.knee_motor;
      // A spring across the knee, parallel to its motor, at rest standing (none when its stiffness is 0).
      const double parallel = -model.knee_parallel_spring.stiffness_nm_per_rad * (beta - model.knee_stand_flexion_rad) -
                              model.knee_parallel_spring.damping_nm_s_per_rad * beta_rate;
      if (model.knee_drive == PlanarLegModel::KneeDrive::kPositionPd) {
        // Knee driven directly: a PD on the flexion within the motor's torque-speed line; the motor turns
        // with the knee.
        const double target = model.knee_stand_flexion_rad + cmd.knee_flexion_rad;
        const double flex = limit_torque(km.kp_nm_per_rad * (target - beta) - km.kd_nm_s_per_rad * beta_rate, beta_rate, km);
        // The gearbox drags whether the motor drives or is back-driven, as the hip's does.
        const double gearbox = -km.viscous_friction_nm_s_per_rad * beta_rate;
        leg.knee.add_torque(-(flex + parallel + gearbox) +
                            dry_friction(model.knee_joint_friction_nm + km.coulomb_friction_nm, leg.knee.rate()));
        leg.knee_torque = flex;
        leg.knee_motor_speed = beta_rate;
        if (leg.foot != nullptr) apply_biarticular(leg);
        continue;
      }
      // Knee: the motor positions the rest angle of the series knee spring. Its output moves within its
      // torque-speed line (knee_speed_limit) and is back-driven when the spring torque exceeds the stall
      // torque.
      const double k = model.knee_spring.stiffness_nm_per_rad;
      const double target = model.knee_stand_flexion_rad + cmd.knee_flexion_rad;
      double speed = model.knee_motor_bandwidth_per_s * (target - leg.knee_motor_flexion);
      const double held = k * (leg.knee_motor_flexion - beta);  // the motor's torque, + flexing
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
      // Positive hinge torque extends the knee; the bearing's friction opposes the hinge's own rate.
      leg.knee.add_torque(-(flex_torque + parallel) + dry_friction(model.knee_joint_friction_nm, leg.knee.rate()));
      leg.knee_torque = spring_torque;
      if (leg.foot != nullptr) apply_biarticular(leg);
    }
  }

  // Biarticular spring: holds the foot parallel to the femur (the parallel mechanism's rest).
  void apply_biarticular(const LegBodies& leg) {
    const double deviation = leg.knee.angle() + leg.ankle.angle();
    const double deviation_rate = leg.knee.rate() + leg.ankle.rate();
    const double tau_b = -model.biarticular_spring.stiffness_nm_per_rad * deviation -
                         model.biarticular_spring.damping_nm_s_per_rad * deviation_rate;
    // About the leg's joint axis (every joint of a leg turns about the same one; z on a rail).
    const LegJoint::Axis n = leg.knee.axis();
    dBodyAddTorque(leg.foot, tau_b * n.x, tau_b * n.y, tau_b * n.z);
    dBodyAddTorque(leg.femur, -tau_b * n.x, -tau_b * n.y, -tau_b * n.z);
  }

  // The stop motors learn the joint angles they limit (LegJoint::update_stops) before every solve.
  void update_joint_stops() {
    for (const auto& leg : legs) {
      leg.knee.update_stops();
      if (leg.foot != nullptr) leg.ankle.update_stops();
    }
  }

  void collide() {
    contacts_this_step.clear();
    dContactGeom geoms[kMaxContactsPerToe];
    const auto& c = model.contact;
    const double erp = dt * c.stiffness_n_per_m / (dt * c.stiffness_n_per_m + c.damping_n_s_per_m);
    const double cfm = 1.0 / (dt * c.stiffness_n_per_m + c.damping_n_s_per_m);
    std::size_t fb_index = 0;
    for (std::size_t i = 0; i < legs.size(); ++i) {
      legs[i].normal_force = 0.0;
      // Let the hash space find the terrain geoms near this toe (rough ground has hundreds of tiles).
      ToeContacts found{legs[i].toe, geoms, 0};
      dSpaceCollide2(legs[i].toe, reinterpret_cast<dGeomID>(terrain_space), &found, &ToeContacts::near_callback);
      const int used = found.count;
      for (int k = 0; k < used; ++k) {
        dContact contact{};
        contact.geom = geoms[k];
        contact.surface.mode = dContactApprox1 | dContactSoftERP | dContactSoftCFM;
        contact.surface.mu = c.friction;
        contact.surface.soft_erp = erp;
        contact.surface.soft_cfm = cfm;
        // On a rail: friction along the ground's in-plane tangent only: every force of the model lies in the
        // plane, so an out-of-plane friction row would carry nothing but costs the solver a row (mu2 = 0
        // drops it). A free robot's feet also push sideways: both tangents get the friction coefficient (the
        // pyramid of dContactApprox1, as ODE builds it without dContactMu2).
        const double* n = geoms[k].normal;
        const double tangent_norm = std::hypot(n[0], n[1]);
        if (model.planar && tangent_norm > 1e-9) {
          contact.surface.mode |= dContactMu2 | dContactFDir1;
          contact.surface.mu2 = 0.0;
          contact.fdir1[0] = n[1] / tangent_norm;  // (1, 0, 0) on level ground
          contact.fdir1[1] = -n[0] / tangent_norm;
          contact.fdir1[2] = 0.0;
        }
        if (terrain.treadmill_speed_mps != 0.0) {
          contact.surface.mode |= dContactMotion1 | dContactFDir1;
          contact.fdir1[0] = 1.0;
          contact.fdir1[1] = 0.0;
          contact.fdir1[2] = 0.0;
          contact.surface.motion1 = -belt_speed();  // the belt surface moves backwards (-x)
        }
        dJointID j = dJointCreateContact(world, contact_group, &contact);
        dJointAttach(j, legs[i].toe_body, nullptr);
        if (fb_index < contact_feedback.size()) {
          dJointSetFeedback(j, &contact_feedback[fb_index]);
          contacts_this_step.push_back({static_cast<int>(i), {geoms[k].normal[0], geoms[k].normal[1], geoms[k].normal[2]}});
          ++fb_index;
        }
      }
    }
  }

  void read_contact_forces() {
    for (std::size_t k = 0; k < contacts_this_step.size(); ++k) {
      const ActiveContact& c = contacts_this_step[k];
      const dJointFeedback& fb = contact_feedback[k];
      // The contact normal points into the foot; the force on the foot along it is the normal force.
      const double fn = fb.f1[0] * c.normal[0] + fb.f1[1] * c.normal[1] + fb.f1[2] * c.normal[2];
      legs[c.leg].normal_force += std::max(0.0, fn);
    }
  }

  // The FootTile's reading: the contact force scaled by its sensitivity and lagged by its time constant
  // (implicit Euler, exact at tau = 0 and stable for any tau).
  void update_foot_sensors() {
    const double tau = model.foot_sensor.time_constant_s;
    const double blend = dt / (tau + dt);
    for (auto& leg : legs) {
      leg.sensed_force += blend * (model.foot_sensor.sensitivity * leg.normal_force - leg.sensed_force);
    }
  }

  // Keeps a body in the plane z = 0 turning about z only: removes the round-off that the solver leaves
  // out of the plane (the joints do not constrain it, see PlanarJoint; Plane2D lets the trunk drift too).
  static void project_onto_plane(dBodyID body) {
    const dReal* q = dBodyGetQuaternion(body);
    const double norm = std::hypot(q[0], q[3]);
    dQuaternion fixed{q[0] / norm, 0, 0, q[3] / norm};
    dBodySetQuaternion(body, fixed);
    remember_angle_z(body);
    const dReal* w = dBodyGetAngularVel(body);
    dBodySetAngularVel(body, 0, 0, w[2]);
    const dReal* p = dBodyGetPosition(body);
    dBodySetPosition(body, p[0], p[1], 0.0);
    const dReal* v = dBodyGetLinearVel(body);
    dBodySetLinearVel(body, v[0], v[1], 0.0);
  }

  void project_onto_plane() {
    if (!model.planar) return;  // a free robot leaves the plane by right
    project_onto_plane(trunk);
    for (const auto& leg : legs) {
      project_onto_plane(leg.femur);
      project_onto_plane(leg.shank);
      if (leg.foot != nullptr) project_onto_plane(leg.foot);
    }
  }

  void step() {
    if (moving_ground && !shifted && time >= terrain.shift_time_s) {
      dGeomPlaneSetParams(moving_ground, 0, 1, 0, terrain.shift_height_m);
      shifted = true;
    }
    apply_actuators();
    update_joint_stops();
    collide();
    belt_travel += belt_speed() * dt;
    dWorldStep(world, dt);
    read_contact_forces();
    update_foot_sensors();
    dJointGroupEmpty(contact_group);
    project_onto_plane();
    time += dt;
  }
};

OdePlant::OdePlant(const PlanarLegModel& model, const TerrainSpec& terrain, std::uint64_t seed)
    : impl_(std::make_unique<Impl>(model, terrain, seed)) {}

OdePlant::~OdePlant() = default;

void OdePlant::command(const PerLeg<JointCommand>& commands) {
  if (commands.size() != impl_->legs.size()) throw std::invalid_argument("OdePlant::command: one command per leg");
  impl_->commands = commands;
}

void OdePlant::advance(double dt_s) {
  const long steps = std::max(1L, std::lround(dt_s / impl_->dt));
  for (long i = 0; i < steps; ++i) impl_->step();
}

double OdePlant::time_step_s() const { return impl_->dt; }

double OdePlant::largest_joint_gap_m() const {
  double gap = 0.0;
  for (const auto& leg : impl_->legs) {
    gap = std::max({gap, leg.hip.gap_m(), leg.knee.gap_m()});
    if (leg.foot != nullptr) gap = std::max(gap, leg.ankle.gap_m());
  }
  return gap;
}

std::optional<EnergyModel> OdePlant::energy_model() const {
  const PlanarLegModel& m = impl_->model;
  return EnergyModel{line_of(m.hip_motor), line_of(m.knee_motor), m.total_mass_kg(), m.gravity_m_s2};
}

PlantState OdePlant::state() const {
  const Impl& m = *impl_;
  PlantState s;
  s.time_s = m.time;
  const dReal* p = dBodyGetPosition(m.trunk);
  const dReal* v = dBodyGetLinearVel(m.trunk);
  s.trunk.x_m = p[0] + m.belt_travel;
  s.trunk.vx_mps = v[0] + m.belt_speed();
  s.trunk.height_m = p[1];
  if (m.model.planar) {
    s.trunk.pitch_rad = body_angle_z(m.trunk);
  } else {
    // From the trunk's rotation (row-major 3x4): its forward axis (column 0) and its right axis (column 2) in
    // the world. Pitch: the forward axis's elevation; roll: the right axis's depression (+ left side up);
    // yaw: the forward axis's heading, + turned left (towards -z).
    const dReal* r = dBodyGetRotation(m.trunk);
    s.trunk.pitch_rad = std::atan2(r[4], std::hypot(r[0], r[8]));
    s.trunk.roll_rad = std::atan2(-r[6], std::hypot(r[2], r[10]));
    s.trunk.yaw_rad = std::atan2(-r[8], r[0]);
    s.trunk.lateral_m = -p[2];
  }
  s.legs = PerLeg<LegState>(m.legs.size());
  for (std::size_t i = 0; i < m.legs.size(); ++i) {
    const auto& leg = m.legs[i];
    s.legs[i].hip_angle_rad = leg.hip.angle();
    s.legs[i].knee_flexion_rad = m.knee_flexion(leg) - m.model.knee_stand_flexion_rad;
    s.legs[i].hip_torque_nm = leg.hip_torque;
    s.legs[i].knee_torque_nm = leg.knee_torque;
    s.legs[i].hip_speed_rad_s = leg.hip.rate();
    s.legs[i].knee_motor_speed_rad_s = leg.knee_motor_speed;
    s.legs[i].foot_normal_force_n = leg.sensed_force;  // as the foot sensor reports it
  }
  return s;
}

}  // namespace cpgmatch::sim

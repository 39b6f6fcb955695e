#include "cpgmatch/energy.hpp"

#include <algorithm>
#include <cmath>

namespace cpgmatch {
namespace {

// Accumulates one joint's drive, sample by sample.
struct JointIntegral {
  double positive_work = 0.0, joule = 0.0, electrical = 0.0, torque_sum = 0.0;
  bool unmeasured = false;  // a sample without a speed (a plant that does not measure it): no power

  void hold(const JointDrive& d, double seconds, const DcMotorLine* motor) {
    const double mechanical = d.torque_nm * d.speed_rad_s;
    // std::max(0.0, NaN) is 0.0: an unmeasured speed must not pass for a motor at rest.
    if (!std::isfinite(mechanical)) {
      unmeasured = true;
      return;
    }
    positive_work += std::max(0.0, mechanical) * seconds;
    if (motor == nullptr) return;
    const double heat = d.torque_nm * d.torque_nm * motor->joule_coefficient();
    joule += heat * seconds;
    electrical += std::max(0.0, mechanical + heat) * seconds;
  }

  JointEnergy result(std::size_t samples, bool modelled) const {
    JointEnergy e;
    e.signed_mean_torque_nm = torque_sum / static_cast<double>(samples);
    if (unmeasured) return e;
    e.positive_work_j = positive_work;
    if (modelled) {
      e.joule_loss_j = joule;
      e.electrical_j = electrical;
    }
    return e;
  }
};

}  // namespace

EnergyMeasures EnergyRecorder::evaluate(double distance_m, double min_distance_m) const {
  EnergyMeasures out;
  if (samples_.size() < 2) return out;
  const DcMotorLine* hip_motor = model_ ? &model_->hip : nullptr;
  const DcMotorLine* knee_motor = model_ ? &model_->knee : nullptr;
  const std::size_t legs = samples_.front().hip.size();
  PerLeg<JointIntegral> hip(legs), knee(legs);
  for (std::size_t i = 0; i < samples_.size(); ++i) {
    const EnergySample& s = samples_[i];
    const double held = i + 1 < samples_.size() ? samples_[i + 1].time_s - s.time_s : 0.0;
    for (std::size_t leg = 0; leg < legs; ++leg) {
      hip[leg].hold(s.hip[leg], held, hip_motor);
      knee[leg].hold(s.knee[leg], held, knee_motor);
      hip[leg].torque_sum += s.hip[leg].torque_nm;
      knee[leg].torque_sum += s.knee[leg].torque_nm;
    }
  }
  const bool modelled = model_.has_value();
  double hip_work = 0.0, knee_work = 0.0, joule = 0.0, electrical = 0.0, signed_torque = 0.0;
  out.hip = PerLeg<JointEnergy>(legs);
  out.knee = PerLeg<JointEnergy>(legs);
  for (std::size_t leg = 0; leg < legs; ++leg) {
    out.hip[leg] = hip[leg].result(samples_.size(), modelled);
    out.knee[leg] = knee[leg].result(samples_.size(), modelled);
    hip_work += out.hip[leg].positive_work_j;  // NaN, when unmeasured or without a model, stays NaN
    knee_work += out.knee[leg].positive_work_j;
    joule += out.hip[leg].joule_loss_j + out.knee[leg].joule_loss_j;
    electrical += out.hip[leg].electrical_j + out.knee[leg].electrical_j;
    signed_torque += std::abs(out.hip[leg].signed_mean_torque_nm) + std::abs(out.knee[leg].signed_mean_torque_nm);
  }
  const double duration = samples_.back().time_s - samples_.front().time_s;
  const double distance = std::max(distance_m, min_distance_m);
  out.positive_work_j = hip_work + knee_work;
  out.hip_positive_work_j_per_m = hip_work / distance;
  out.knee_positive_work_j_per_m = knee_work / distance;
  out.positive_work_j_per_m = out.positive_work_j / distance;
  out.signed_torque_per_speed = duration > 0.0 ? signed_torque / (distance / duration) : std::nan("");
  if (modelled) {
    out.joule_loss_j = joule;
    out.electrical_j = electrical;
    const double weight_distance = model_->total_mass_kg * model_->gravity_m_s2 * distance;
    out.mechanical_cost_of_transport = out.positive_work_j / weight_distance;
    out.electrical_cost_of_transport = electrical / weight_distance;
  }
  return out;
}

}  // namespace cpgmatch

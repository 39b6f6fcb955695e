// The energy measures (energy.hpp) on synthetic drive traces whose work and Joule loss are known in
// closed form.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "cpgmatch/energy.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch {
namespace {

constexpr double kPi = std::numbers::pi;

// 4 N m stall torque, 12 rad/s no-load speed: R / k^2 = 12 / 4 = 3 W per (N m)^2.
EnergyModel morti_like() { return EnergyModel{{4.0, 12.0}, {4.0, 12.0}, 4.0, 9.81}; }

// `seconds` of samples at 500 Hz; every joint gets the same drive(t).
template <typename Drive>
EnergyRecorder recorded(std::optional<EnergyModel> model, double seconds, Drive drive) {
  EnergyRecorder r(model);
  const int n = static_cast<int>(std::lround(seconds * 500.0));
  for (int i = 0; i <= n; ++i) {
    EnergySample s;
    s.hip = s.knee = PerLeg<JointDrive>(test::kNumLegs);
    s.time_s = 10.0 + i / 500.0;  // an evaluation window starts after the entrainment
    for (int leg = 0; leg < kNumLegs; ++leg) s.hip[leg] = s.knee[leg] = drive(i / 500.0);
    r.add(s);
  }
  return r;
}

TEST(Energy, JointCoefficientIsNoLoadSpeedOverStallTorqueWhateverTheVoltage) {
  // R / k^2 from a motor of supply V: k = V / w0, R = V k / ts -> R / k^2 = w0 / ts for every V.
  for (const double volts : {6.0, 12.0, 24.0}) {
    const double k = volts / 12.0, resistance = volts * k / 4.0;
    const DcMotorLine line{4.0, 12.0};
    EXPECT_NEAR(resistance / (k * k), line.joule_coefficient(), 1e-12) << volts;
  }
}

TEST(Energy, ASteadyTorqueOnAnOscillatingJointDoesHalfCycleWorkAndHeatsByTorqueSquared) {
  // tau = 2 N m, w = 3 sin(2 pi t) rad/s for 10 s: positive work per joint = 10 x 2 x 3 / pi J (the
  // positive half of each cycle), Joule loss = 2^2 x 3 x 10 = 120 J, and since 6 sin + 12 > 0 the motor
  // always draws: electrical = net mechanical (0 over whole cycles) + Joule = 120 J.
  const auto r = recorded(morti_like(), 10.0, [](double t) { return JointDrive{2.0, 3.0 * std::sin(2 * kPi * t)}; });
  const EnergyMeasures e = r.evaluate(3.0, 0.25);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    EXPECT_NEAR(e.hip[leg].positive_work_j, 60.0 / kPi, 1e-3);
    EXPECT_NEAR(e.knee[leg].joule_loss_j, 120.0, 1e-9);
    EXPECT_NEAR(e.knee[leg].electrical_j, 120.0, 1e-6);
    EXPECT_NEAR(e.hip[leg].signed_mean_torque_nm, 2.0, 1e-12);
  }
  EXPECT_NEAR(e.positive_work_j, 8 * 60.0 / kPi, 1e-2);
  EXPECT_NEAR(e.hip_positive_work_j_per_m, 4 * 60.0 / kPi / 3.0, 1e-3);
  EXPECT_NEAR(e.positive_work_j_per_m, 8 * 60.0 / kPi / 3.0, 1e-3);
  EXPECT_NEAR(e.joule_loss_j, 960.0, 1e-6);
  EXPECT_NEAR(e.electrical_j, 960.0, 1e-4);
  const double weight_distance = 4.0 * 9.81 * 3.0;
  EXPECT_NEAR(e.electrical_cost_of_transport, 960.0 / weight_distance, 1e-6);
  EXPECT_NEAR(e.mechanical_cost_of_transport, 8 * 60.0 / kPi / weight_distance, 1e-4);
  // 8 joints x |2 N m| at 3 m / 10 s.
  EXPECT_NEAR(e.signed_torque_per_speed, 16.0 / 0.3, 1e-9);
}

TEST(Energy, ABrakingMotorReturnsNothingToTheSupply) {
  // tau = 1 N m, w = 6 sin: the power 6 sin + 3 is negative while sin < -1/2. Drawn only: per cycle
  // (2 a cos(alpha) + b (pi + 2 alpha)) / (2 pi) with a = 6, b = 3, alpha = asin(b / a) = pi / 6, i.e.
  // 36.54 J over 10 s, not the net 30 J.
  const auto r = recorded(morti_like(), 10.0, [](double t) { return JointDrive{1.0, 6.0 * std::sin(2 * kPi * t)}; });
  const EnergyMeasures e = r.evaluate(3.0, 0.25);
  const double alpha = kPi / 6.0;
  const double drawn = 10.0 * (2 * 6.0 * std::cos(alpha) + 3.0 * (kPi + 2 * alpha)) / (2 * kPi);
  EXPECT_NEAR(e.hip[0].electrical_j, drawn, 1e-2);
  EXPECT_GT(e.hip[0].electrical_j, 30.0 + 5.0);
  EXPECT_NEAR(e.hip[0].joule_loss_j, 30.0, 1e-9);
}

TEST(Energy, AJointHeldStillDoesNoWorkButHeats) {
  const auto r = recorded(morti_like(), 2.0, [](double) { return JointDrive{-1.5, 0.0}; });
  const EnergyMeasures e = r.evaluate(0.6, 0.25);
  EXPECT_EQ(e.positive_work_j, 0.0);
  EXPECT_NEAR(e.knee[2].joule_loss_j, 1.5 * 1.5 * 3.0 * 2.0, 1e-9);
  EXPECT_NEAR(e.knee[2].signed_mean_torque_nm, -1.5, 1e-12);
}

TEST(Energy, WithoutAMotorModelOnlyWorkAndTorquesAreMeasuredAndAnUnmeasuredSpeedIsNotZeroWork) {
  const auto plain = recorded(std::nullopt, 1.0, [](double) { return JointDrive{1.0, 2.0}; });
  const EnergyMeasures e = plain.evaluate(1.0, 0.25);
  EXPECT_NEAR(e.positive_work_j, 8 * 2.0, 1e-9);
  EXPECT_TRUE(std::isnan(e.joule_loss_j));
  EXPECT_TRUE(std::isnan(e.electrical_cost_of_transport));
  EXPECT_TRUE(std::isnan(e.mechanical_cost_of_transport));  // no mass either

  const auto blind = recorded(morti_like(), 1.0, [](double) { return JointDrive{1.0, std::nan("")}; });
  const EnergyMeasures b = blind.evaluate(1.0, 0.25);
  EXPECT_TRUE(std::isnan(b.hip[0].positive_work_j));
  EXPECT_TRUE(std::isnan(b.positive_work_j_per_m));
  EXPECT_TRUE(std::isnan(b.electrical_cost_of_transport));
  EXPECT_NEAR(b.hip[0].signed_mean_torque_nm, 1.0, 1e-12);  // the torque was measured
}

TEST(Energy, DistanceIsFlooredLikeJDistance) {
  const auto r = recorded(morti_like(), 1.0, [](double) { return JointDrive{1.0, 1.0}; });
  const EnergyMeasures backwards = r.evaluate(-0.4, 0.25);
  EXPECT_NEAR(backwards.positive_work_j_per_m, 8.0 / 0.25, 1e-9);
  EXPECT_GT(backwards.electrical_cost_of_transport, 0.0);
}

TEST(Energy, FewerThanTwoSamplesMeasureNothing) {
  EnergyRecorder r(morti_like());
  r.add(EnergySample{});
  const EnergyMeasures e = r.evaluate(1.0, 0.25);
  EXPECT_TRUE(std::isnan(e.positive_work_j));
  EXPECT_TRUE(e.hip.empty());  // no per-leg values either
}

}  // namespace
}  // namespace cpgmatch

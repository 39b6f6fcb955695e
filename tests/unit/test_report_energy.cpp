// A report's energy in the store's JSON: every field survives, and a report from before energy reads back
// with every energy field NaN (never 0, which would pass for a measured motor that spent nothing).
#include <cmath>

#include <gtest/gtest.h>

#include "cpgmatch/domain/report_json.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch::domain {
namespace {

RolloutReport measured_report() {
  RolloutReport r;
  r.worker_id = "w";
  r.summary.cost = 1.0;
  r.summary.terms = CostTerms{0.1, 0.3, 0.1, 0.0, 0.0};
  r.summary.distance_m = 3.0;
  r.summary.mean_speed_mps = 0.3;
  EnergyMeasures& e = r.summary.energy;
  e.hip = e.knee = PerLeg<JointEnergy>(test::kNumLegs);
  e.positive_work_j = 90.0;
  e.joule_loss_j = 500.0;
  e.electrical_j = 580.0;
  e.hip_positive_work_j_per_m = 16.0;
  e.knee_positive_work_j_per_m = 14.0;
  e.positive_work_j_per_m = 30.0;
  e.mechanical_cost_of_transport = 0.76;
  e.electrical_cost_of_transport = 4.9;
  e.signed_torque_per_speed = 11.0;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    e.hip[leg] = {1.0 + leg, 50.0 + leg, 60.0 + leg, -0.05 * leg};
    e.knee[leg] = {2.0 + leg, 70.0 + leg, 80.0 + leg, -0.5 - 0.01 * leg};
  }
  return r;
}

TEST(ReportEnergy, EveryFieldSurvivesTheStoresJson) {
  const RolloutReport r = measured_report();
  const nlohmann::json j = to_json(r);
  EXPECT_DOUBLE_EQ(j["energy"]["joints"]["knee"][3]["signed_mean_torque_nm"].get<double>(), -0.53);
  const RolloutReport back = report_from_json(j);
  EXPECT_EQ(to_json(back), j);
  EXPECT_DOUBLE_EQ(back.summary.energy.electrical_cost_of_transport, 4.9);
  EXPECT_DOUBLE_EQ(back.summary.energy.hip[2].joule_loss_j, 52.0);
}

TEST(ReportEnergy, AReportFromBeforeEnergyReadsNaN) {
  nlohmann::json old = to_json(measured_report());
  old.erase("energy");
  const EnergyMeasures e = report_from_json(old).summary.energy;
  EXPECT_TRUE(std::isnan(e.electrical_cost_of_transport));
  EXPECT_TRUE(std::isnan(e.positive_work_j_per_m));
  EXPECT_TRUE(e.knee.empty());  // no per-leg values: a report from before says nothing of its legs
  // Unmeasured fields are null in JSON and NaN again when read.
  nlohmann::json partial = to_json(measured_report());
  partial["energy"]["joints"]["hip"][1].erase("electrical_j");
  partial["energy"]["electrical_j"] = nullptr;
  const EnergyMeasures p = report_from_json(partial).summary.energy;
  EXPECT_TRUE(std::isnan(p.hip[1].electrical_j));
  EXPECT_TRUE(std::isnan(p.electrical_j));
  EXPECT_DOUBLE_EQ(p.hip[1].joule_loss_j, 51.0);
}

}  // namespace
}  // namespace cpgmatch::domain

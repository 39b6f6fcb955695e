// Simulation and hardware in one model: the co-kriging GP (what it learns of rho and the reality gap),
// the transfer GP, and the hardware proposals (better than hardware-only BO, away from predicted falls,
// exact across a restart).
#include <cmath>
#include <cstdio>
#include <algorithm>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "cpgmatch/bo/hardware_optimizer.hpp"
#include "cpgmatch/bo/initial_design.hpp"
#include "cpgmatch/bo/model_state_json.hpp"
#include "cpgmatch/bo/multi_fidelity_gp.hpp"
#include "cpgmatch/bo/optimizer.hpp"
#include "cpgmatch/bo/test_functions.hpp"
#include "cpgmatch/bo/transfer_gp.hpp"
#include "cpgmatch/errors.hpp"

namespace cpgmatch::bo {
namespace {

constexpr double kPi = std::numbers::pi;

// A smooth simulated cost on the unit square (range about -1.5..2.5).
double simulated(const Eigen::VectorXd& x) {
  return std::sin(3.0 * x[0]) + std::cos(4.0 * x[1]) * x[0] + 2.0 * (x[1] - 0.3) * (x[1] - 0.3) - x[0] * x[1];
}

Eigen::VectorXd evaluate(const Eigen::MatrixXd& X, const std::function<double(const Eigen::VectorXd&)>& f) {
  Eigen::VectorXd y(X.rows());
  for (Eigen::Index i = 0; i < X.rows(); ++i) y[i] = f(X.row(i).transpose());
  return y;
}

TEST(MultiFidelityGP, LikelihoodGradientMatchesFiniteDifferences) {
  const Eigen::MatrixXd Xs = make_initial_design(InitialDesign::kSobol, 12, 2, 1);
  const Eigen::MatrixXd Xh = make_initial_design(InitialDesign::kSobol, 5, 2, 2);
  const Eigen::VectorXd ys = evaluate(Xs, simulated);
  const Eigen::VectorXd yh = evaluate(Xh, [](const Eigen::VectorXd& x) { return 0.7 * simulated(x) + 0.3 * x[0]; });
  MultiFidelityGP gp;
  std::mt19937_64 rng(0);
  MultiFidelityHyperparameters h;
  h.simulation.log_amplitude = 0.2;
  h.simulation.log_length_scales = Eigen::Vector2d(-0.5, -0.8);
  h.simulation.log_noise = std::log(1e-3);
  h.discrepancy.log_amplitude = -1.5;
  h.discrepancy.log_length_scales = Eigen::Vector2d(0.1, -0.3);
  h.discrepancy.log_noise = std::log(2e-3);
  h.rho = 0.6;
  gp.fit(Xs, ys, Xh, yh, /*optimise=*/false, rng, &h);
  const Eigen::VectorXd theta = h.pack();
  Eigen::VectorXd grad;
  gp.log_marginal_likelihood(theta, &grad);
  ASSERT_EQ(grad.size(), 9);
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    const double step = 1e-6;
    Eigen::VectorXd up = theta, down = theta;
    up[i] += step;
    down[i] -= step;
    const double numeric = (gp.log_marginal_likelihood(up, nullptr) - gp.log_marginal_likelihood(down, nullptr)) / (2 * step);
    EXPECT_NEAR(grad[i], numeric, 1e-5 * std::max(1.0, std::abs(numeric))) << "parameter " << i;
  }
}

TEST(MultiFidelityGP, WithoutADiscrepancyTheHardwarePosteriorIsTheScaledSimulation) {
  // Hand check of the covariance blocks: with the discrepancy at its smallest amplitude and tiny noise, a
  // hardware point between simulated ones is predicted as rho * sim + beta_d.
  const Eigen::MatrixXd Xs = make_initial_design(InitialDesign::kSobol, 40, 2, 3);
  const Eigen::MatrixXd Xh = make_initial_design(InitialDesign::kSobol, 6, 2, 4);
  const Eigen::VectorXd ys = evaluate(Xs, simulated);
  const Eigen::VectorXd yh = evaluate(Xh, [](const Eigen::VectorXd& x) { return 0.5 * simulated(x) + 2.0; });
  MultiFidelityGP gp;
  std::mt19937_64 rng(1);
  gp.fit(Xs, ys, Xh, yh, /*optimise=*/true, rng);
  const Eigen::Vector2d x(0.37, 0.61);
  EXPECT_NEAR(gp.predict_hardware(x).mean, gp.rho() * gp.predict_simulation(x).mean + gp.constant_discrepancy(), 1e-3);
  EXPECT_NEAR(gp.predict_simulation(x).mean, simulated(x), 2e-2);
}

struct Recovery {
  double rho = 0.0;
  double max_offset_error = 0.0;   // over a 21 x 21 grid, caller's units
  double rms_offset_error = 0.0;
  double rms_hardware_error = 0.0;
  double rms_hardware_only_error = 0.0;  // a plain GP on the same hardware points
};

// 30 simulated and 8 hardware points (Sobol), hardware = 0.8 sim + offset (+ Gaussian noise of std
// robot_noise on each robot result); what the model learned, against the noise-free truth.
Recovery recover(const std::function<double(const Eigen::VectorXd&)>& offset, std::uint64_t seed,
                 double robot_noise = 0.0) {
  const Eigen::MatrixXd Xs = make_initial_design(InitialDesign::kSobol, 30, 2, seed);
  const Eigen::MatrixXd Xh = make_initial_design(InitialDesign::kSobol, 8, 2, seed + 100);
  auto hardware = [&](const Eigen::VectorXd& x) { return 0.8 * simulated(x) + offset(x); };
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, robot_noise);
  Eigen::VectorXd yh = evaluate(Xh, hardware);
  if (robot_noise > 0.0) for (Eigen::Index i = 0; i < yh.size(); ++i) yh[i] += noise(rng);
  MultiFidelityGP gp;
  gp.fit(Xs, evaluate(Xs, simulated), Xh, yh, /*optimise=*/true, rng);
  GaussianProcess hardware_only;
  hardware_only.fit(Xh, yh, true, rng);
  Recovery r;
  r.rho = gp.rho();
  double offset_sq = 0.0, hw_sq = 0.0, hw_only_sq = 0.0;
  int n = 0;
  for (int i = 0; i <= 20; ++i) {
    for (int j = 0; j <= 20; ++j, ++n) {
      const Eigen::Vector2d x(i / 20.0, j / 20.0);
      const double e = gp.predict_discrepancy(x).mean - offset(x);
      r.max_offset_error = std::max(r.max_offset_error, std::abs(e));
      offset_sq += e * e;
      hw_sq += std::pow(gp.predict_hardware(x).mean - hardware(x), 2);
      hw_only_sq += std::pow(hardware_only.predict(x).mean - hardware(x), 2);
    }
  }
  r.rms_offset_error = std::sqrt(offset_sq / n);
  r.rms_hardware_error = std::sqrt(hw_sq / n);
  r.rms_hardware_only_error = std::sqrt(hw_only_sq / n);
  return r;
}

void print(const Recovery& r, const char* what, std::uint64_t seed) {
  std::printf("%s, seed %llu: rho %.4f, offset error max %.4f rms %.4f, hardware rms %.4f (hardware-only GP %.4f)\n", what,
              static_cast<unsigned long long>(seed), r.rho, r.max_offset_error, r.rms_offset_error, r.rms_hardware_error,
              r.rms_hardware_only_error);
}

TEST(MultiFidelityGP, RecoversRhoAndAConstantOffsetFrom30SimulatedAnd8HardwarePoints) {
  for (std::uint64_t seed : {1, 2, 3}) {
    const Recovery r = recover([](const Eigen::VectorXd&) { return 1.5; }, seed);
    print(r, "constant offset 1.5", seed);
    EXPECT_NEAR(r.rho, 0.8, 0.02) << "seed " << seed;
    EXPECT_LT(r.max_offset_error, 0.05) << "seed " << seed;
    EXPECT_LT(r.rms_hardware_error, 0.5 * r.rms_hardware_only_error) << "seed " << seed;
  }
}

TEST(MultiFidelityGP, RecoversRhoAndASmoothOffset) {
  // A gap that grows along x0 and bends along x1: 1 + 0.5 x0 + 0.3 sin(pi x1), spread ~0.8.
  auto offset = [](const Eigen::VectorXd& x) { return 1.0 + 0.5 * x[0] + 0.3 * std::sin(kPi * x[1]); };
  for (std::uint64_t seed : {1, 2, 3}) {
    const Recovery r = recover(offset, seed);
    print(r, "smooth offset", seed);
    EXPECT_NEAR(r.rho, 0.8, 0.1) << "seed " << seed;
    EXPECT_LT(r.rms_offset_error, 0.1) << "seed " << seed;
    EXPECT_LT(r.rms_hardware_error, 0.5 * r.rms_hardware_only_error) << "seed " << seed;
  }
}

TEST(MultiFidelityGP, RecoversRhoAndAConstantOffsetFromNoisyRobotResults) {
  // The robot's results carry noise of std 0.05 (about 1.5% of the cost's range); the simulation none.
  // Looser than noise-free: 8 noisy points pin rho to a few hundredths at best, and on seed 1 the
  // likelihood prefers a bumpy discrepancy through the noise (robot noise at its floor) to a noise term,
  // so the offset is off by up to 0.17 there (rms 0.065).
  for (std::uint64_t seed : {1, 2, 3}) {
    const Recovery r = recover([](const Eigen::VectorXd&) { return 1.5; }, seed, 0.05);
    print(r, "constant offset 1.5, robot noise 0.05", seed);
    EXPECT_NEAR(r.rho, 0.8, 0.1) << "seed " << seed;
    EXPECT_LT(r.rms_offset_error, 0.1) << "seed " << seed;
    EXPECT_LT(r.rms_hardware_error, 0.5 * r.rms_hardware_only_error) << "seed " << seed;
  }
}

TEST(TransferGP, TheHardwarePosteriorIsTheSimulationsMeanPlusALearnedResidual) {
  const Eigen::MatrixXd Xs = make_initial_design(InitialDesign::kSobol, 30, 2, 5);
  const Eigen::MatrixXd Xh = make_initial_design(InitialDesign::kSobol, 8, 2, 6);
  auto hardware = [](const Eigen::VectorXd& x) { return simulated(x) + 0.7 + 0.2 * x[0]; };
  TransferGP gp;
  std::mt19937_64 rng(2);
  // No hardware yet: the simulation's posterior itself.
  gp.fit(Xs, evaluate(Xs, simulated), Eigen::MatrixXd(0, 2), Eigen::VectorXd(0), true, rng);
  const Eigen::Vector2d x(0.42, 0.77);
  EXPECT_EQ(gp.predict_hardware(x).mean, gp.predict_simulation(x).mean);
  gp.fit(Xs, evaluate(Xs, simulated), Xh, evaluate(Xh, hardware), true, rng);
  double sq = 0.0;
  for (int i = 0; i <= 10; ++i)
    for (int j = 0; j <= 10; ++j) sq += std::pow(gp.predict_hardware(Eigen::Vector2d(i / 10.0, j / 10.0)).mean -
                                                  hardware(Eigen::Vector2d(i / 10.0, j / 10.0)), 2);
  EXPECT_LT(std::sqrt(sq / 121), 0.05);
  // The saved hyperparameters reproduce the fit without optimising.
  const TransferHyperparameters h = gp.hyperparameters();
  TransferGP again;
  again.fit(Xs, evaluate(Xs, simulated), Xh, evaluate(Xh, hardware), false, rng, &h);
  EXPECT_EQ(again.predict_hardware(x).mean, gp.predict_hardware(x).mean);
}

TEST(HardwareProposal, ACandidateAboveTheFallLimitIsNotChosenWhileASaferOneExists) {
  // The most promising candidate (EI 5) is likely to fall; of the two under the limit the better one wins.
  const CandidateChoice c = choose_hardware_candidate(Eigen::Vector3d(5.0, 1.0, 0.5), Eigen::Vector3d(0.9, 0.1, 0.05), 0.2);
  EXPECT_EQ(c.index, 1);
  EXPECT_TRUE(c.within_fall_limit);
  // All above the limit: the least likely to fall, flagged.
  const CandidateChoice all = choose_hardware_candidate(Eigen::Vector3d(5.0, 1.0, 0.5), Eigen::Vector3d(0.9, 0.6, 0.7), 0.2);
  EXPECT_EQ(all.index, 1);
  EXPECT_FALSE(all.within_fall_limit);
}

// A bowl with its minimum at (0.7, 0.6); the robot's cost is 0.8 of it plus 0.5.
double bowl(const Eigen::VectorXd& x) { return 3.0 * (x[0] - 0.7) * (x[0] - 0.7) + 2.0 * (x[1] - 0.6) * (x[1] - 0.6); }
double robot_bowl(const Eigen::VectorXd& x) { return 0.8 * bowl(x) + 0.5; }

SearchSpace unit_square() { return SearchSpace({{"a", 0.0, 1.0, false, ""}, {"b", 0.0, 1.0, false, ""}}); }

// Simulated results over the square (none fell unless `fell_near` says so) and four hardware results
// away from the bowl's minimum, none of them a fall.
void tell_bowl(HardwareOptimizer& hw, const std::function<bool(const Eigen::VectorXd&)>& fell_near) {
  const Eigen::MatrixXd Xs = make_initial_design(InitialDesign::kSobol, 40, 2, 9);
  for (Eigen::Index i = 0; i < Xs.rows(); ++i) {
    const Eigen::VectorXd x = Xs.row(i).transpose();
    hw.tell_simulation({x, bowl(x), false, fell_near(x)});
  }
  for (const Eigen::Vector2d& x : {Eigen::Vector2d(0.2, 0.2), Eigen::Vector2d(0.2, 0.9), Eigen::Vector2d(0.9, 0.1),
                                  Eigen::Vector2d(0.45, 0.35)}) {
    hw.tell_hardware({x, robot_bowl(x)});
  }
}

double from_minimum(const Eigen::VectorXd& x) { return (x - Eigen::Vector2d(0.7, 0.6)).norm(); }
bool near_minimum(const Eigen::VectorXd& x) { return from_minimum(x) < 0.15; }

TEST(HardwareOptimizer, AProposalWhereTheRobotFellIsNotSentWhileASaferOneExists) {
  HardwareOptimizerOptions options;
  options.seed = 4;
  HardwareOptimizer with_falls(unit_square(), options), without_falls(unit_square(), options);
  for (HardwareOptimizer* hw : {&with_falls, &without_falls}) {
    tell_bowl(*hw, [](const Eigen::VectorXd&) { return false; });
    // The robot fell on a ring around the minimum (the costs are still what it measured, a little above
    // the minimum's, so the hardware posterior still promises most at the centre).
    for (const Eigen::Vector2d& x : {Eigen::Vector2d(0.8, 0.6), Eigen::Vector2d(0.6, 0.6), Eigen::Vector2d(0.7, 0.7),
                                     Eigen::Vector2d(0.7, 0.5)}) {
      hw->tell_hardware({x, robot_bowl(x), false, hw == &with_falls});
    }
  }
  const HardwareProposal blind = without_falls.ask();
  const HardwareProposal safe = with_falls.ask();
  std::printf("blind proposal (%.3f, %.3f) P(fall) %.3f EI %.4f; safe proposal (%.3f, %.3f) P(fall) %.3f EI %.4f\n",
              blind.x[0], blind.x[1], with_falls.fall_probability(blind.x), blind.expected_improvement, safe.x[0],
              safe.x[1], safe.fall_probability, safe.expected_improvement);
  // Without the falls the model proposes inside the ring, where the classifier says the robot falls.
  EXPECT_LT(from_minimum(blind.x), 0.1) << blind.x.transpose();
  EXPECT_GT(with_falls.fall_probability(blind.x), options.max_fall_probability);
  // With them, a proposal under the limit, outside the ring.
  EXPECT_TRUE(safe.within_fall_limit);
  EXPECT_LE(safe.fall_probability, options.max_fall_probability);
  EXPECT_NEAR(safe.fall_probability, with_falls.fall_probability(safe.x), 1e-12);
  EXPECT_GT(from_minimum(safe.x), 0.1) << safe.x.transpose();
}

TEST(HardwareOptimizer, WhereTheSimulationFallsTheRobotIsNotSent) {
  // The other source: no robot fall yet, but the simulation fell around the minimum.
  HardwareOptimizerOptions options;
  options.seed = 5;
  HardwareOptimizer hw(unit_square(), options);
  tell_bowl(hw, near_minimum);
  options.fall_model = false;
  HardwareOptimizer blind(unit_square(), options);
  tell_bowl(blind, near_minimum);
  const HardwareProposal p = hw.ask(), b = blind.ask();
  std::printf("blind proposal (%.3f, %.3f) P(fall) %.3f; safe proposal (%.3f, %.3f) P(fall) %.3f\n", b.x[0], b.x[1],
              hw.fall_probability(b.x), p.x[0], p.x[1], p.fall_probability);
  EXPECT_GT(hw.fall_probability(b.x), options.max_fall_probability);
  EXPECT_TRUE(p.within_fall_limit);
  EXPECT_LE(p.fall_probability, options.max_fall_probability);
  EXPECT_GT(from_minimum(p.x), from_minimum(b.x));
}

TEST(HardwareOptimizer, ARestoredOptimizerPredictsAndProposesExactlyWhatTheOriginalWould) {
  for (HardwareStrategy strategy : {HardwareStrategy::kMultiFidelity, HardwareStrategy::kTransfer}) {
    HardwareOptimizerOptions options;
    options.strategy = strategy;
    options.seed = 7;
    options.hyperparameter_restart_every = 2;  // both kinds of fit (warm and with restarts) within the run
    auto robot = [](const Eigen::VectorXd& x) { return 0.8 * simulated(x) + 0.4 + 0.3 * x[1]; };
    auto robot_falls = [](const Eigen::VectorXd& x) { return x[0] > 0.85; };
    HardwareOptimizer original(unit_square(), options);
    const Eigen::MatrixXd Xs = make_initial_design(InitialDesign::kSobol, 26, 2, 11);
    for (Eigen::Index i = 0; i < Xs.rows(); ++i) {
      const Eigen::VectorXd x = Xs.row(i).transpose();
      original.tell_simulation({x, simulated(x), false, x[1] < 0.1});  // simulated falls too
    }
    original.tell_hardware({Eigen::Vector2d(0.95, 0.5), robot(Eigen::Vector2d(0.95, 0.5)), false, true});
    original.tell_hardware({Eigen::Vector2d(0.3, 0.5), robot(Eigen::Vector2d(0.3, 0.5))});
    auto step = [&](HardwareOptimizer& hw, int k) {
      if (k % 2 == 1) {  // simulations go on meanwhile
        const Eigen::Vector2d x(0.1 * k, 0.05 * k + 0.3);
        hw.tell_simulation({x, simulated(x)});
      }
      const HardwareProposal p = hw.ask();
      hw.tell_hardware({p.x, robot(p.x), false, robot_falls(p.x)});
      return p;
    };
    for (int k = 0; k < 3; ++k) step(original, k);
    // Saved after the third result (the last fit was at the third ask), through JSON as a store keeps it.
    const std::string saved = hardware_model_state_to_json(original.model_state()).dump();
    HardwareOptimizer restored =
        HardwareOptimizer::restore(unit_square(), options, original.simulation_observations(),
                                   original.hardware_observations(), hardware_model_state_from_json(nlohmann::json::parse(saved)));
    const char* name = strategy == HardwareStrategy::kTransfer ? "transfer" : "multi_fidelity";
    for (const Eigen::Vector2d& x : {Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d(0.8, 0.9)}) {
      EXPECT_EQ(restored.predict_hardware(x).mean, original.predict_hardware(x).mean) << name;
      EXPECT_EQ(restored.predict_hardware(x).std, original.predict_hardware(x).std) << name;
      EXPECT_EQ(restored.fall_probability(x), original.fall_probability(x)) << name;
    }
    EXPECT_EQ(hardware_model_state_to_json(restored.model_state()).dump(), saved) << name;
    for (int k = 3; k < 7; ++k) {
      const HardwareProposal a = step(original, k), b = step(restored, k);
      EXPECT_EQ(a.x, b.x) << name << " proposal " << k;
      EXPECT_EQ(a.expected_improvement, b.expected_improvement) << name << " proposal " << k;
    }
    const std::vector<Eigen::VectorXd> pending{Eigen::Vector2d(0.5, 0.5)};
    EXPECT_EQ(original.ask(pending).x, restored.ask(pending).x) << name;
    ASSERT_TRUE(original.recommended() && restored.recommended());
    EXPECT_EQ(original.recommended()->observation, restored.recommended()->observation) << name;
    EXPECT_EQ(original.recommended()->predicted, restored.recommended()->predicted) << name;
  }
}

TEST(HardwareOptimizer, AStateSavedBeforeTheLatestResultsRestoresExactlyToo) {
  // Saved, then two more results arrived before the restart: the restored optimizer fits for them at
  // its next ask, warm-started from the saved fit, as the original does.
  HardwareOptimizerOptions options;
  options.seed = 8;
  HardwareOptimizer original(unit_square(), options);
  tell_bowl(original, [](const Eigen::VectorXd&) { return false; });
  original.ask();
  const HardwareModelState early = original.model_state();
  original.tell_hardware({Eigen::Vector2d(0.6, 0.5), robot_bowl(Eigen::Vector2d(0.6, 0.5))});
  original.tell_simulation({Eigen::Vector2d(0.6, 0.5), bowl(Eigen::Vector2d(0.6, 0.5))});
  HardwareOptimizer restored = HardwareOptimizer::restore(unit_square(), options, original.simulation_observations(),
                                                          original.hardware_observations(), early);
  EXPECT_EQ(original.ask().x, restored.ask().x);
  EXPECT_THROW(HardwareOptimizer::restore(unit_square(), options, {}, original.hardware_observations(), early), InputError);
}

TEST(HardwareProposal, ACandidateOutsideTheCostBoundIsNotChosenWhileOneWithinItExists) {
  // EI 5 is under the fall limit but its pessimistic cost (3.0) is above the limit 2.0: the next best
  // score within both wins.
  const Eigen::Vector4d ei(5.0, 1.0, 0.5, 9.0), p_fall(0.1, 0.1, 0.05, 0.9), upper(3.0, 1.9, 1.0, 0.5);
  const CandidateChoice c = choose_hardware_candidate(ei, p_fall, 0.2, upper, 2.0);
  EXPECT_EQ(c.index, 1);
  EXPECT_TRUE(c.within_fall_limit);
  EXPECT_TRUE(c.within_cost_bound);
  // None under the fall limit within the bound: the lowest bound among those under the fall limit (not the
  // one above it, whose bound is lower still), flagged.
  const CandidateChoice tight = choose_hardware_candidate(ei, p_fall, 0.2, upper, 0.8);
  EXPECT_EQ(tight.index, 2);
  EXPECT_TRUE(tight.within_fall_limit);
  EXPECT_FALSE(tight.within_cost_bound);
  // No bound (the three-argument form): the old choice.
  EXPECT_EQ(choose_hardware_candidate(ei, p_fall, 0.2).index, 0);
}

// 40 Sobol points of the bowl in simulation and one lucky rollout: at (0.15, 0.15), far from the bowl's
// minimum, the simulation measured less than anywhere else (a noisy rollout: its neighbours cost 2-3).
// The model smooths it away, so the best point by the model is near the bowl's minimum, the best
// simulated observation is the lucky one. And the lowest cost of all fell (a fall is never the start).
void tell_bowl_with_a_lucky_rollout(HardwareOptimizer& hw) {
  const Eigen::MatrixXd Xs = make_initial_design(InitialDesign::kSobol, 40, 2, 9);
  for (Eigen::Index i = 0; i < Xs.rows(); ++i) {
    const Eigen::VectorXd x = Xs.row(i).transpose();
    hw.tell_simulation({x, bowl(x)});
  }
  hw.tell_simulation({Eigen::Vector2d(0.15, 0.15), -0.05});
  hw.tell_simulation({Eigen::Vector2d(0.9, 0.9), -0.5, false, /*fell=*/true});
}

TEST(HardwareOptimizer, TheFirstProposalIsTheBestSimulatedPointThatDidNotFallNotTheModelsBest) {
  for (HardwareStrategy strategy : {HardwareStrategy::kMultiFidelity, HardwareStrategy::kTransfer}) {
    SCOPED_TRACE(to_string(strategy));
    HardwareOptimizerOptions options;
    options.strategy = strategy;
    options.seed = 3;
    HardwareOptimizer hw(unit_square(), options);
    tell_bowl_with_a_lucky_rollout(hw);
    const HardwareProposal first = hw.ask();
    EXPECT_EQ(first.x, Eigen::Vector2d(0.15, 0.15));  // the point itself, bit for bit
    EXPECT_EQ(first.basis, ProposalBasis::kSimulationOptimum);
    EXPECT_TRUE(std::isnan(first.cost_limit)) << "no robot cost to bound it by";
    EXPECT_TRUE(first.within_cost_bound);
    EXPECT_NEAR(first.fall_probability, hw.fall_probability(first.x), 1e-12);
    // The model's own best: the observed point with the lowest hardware posterior mean, and the proposal
    // the model makes once a robot point is pending. Neither is the start point here.
    std::size_t by_model = 0;
    for (std::size_t i = 0; i < hw.simulation_observations().size(); ++i) {
      if (hw.predict_hardware(hw.simulation_observations()[i].x).mean <
          hw.predict_hardware(hw.simulation_observations()[by_model].x).mean) {
        by_model = i;
      }
    }
    const Eigen::VectorXd model_best = hw.simulation_observations()[by_model].x;
    std::printf("%s: start (%.3f, %.3f); lowest posterior mean at observed (%.3f, %.3f)\n", to_string(strategy).c_str(),
                first.x[0], first.x[1], model_best[0], model_best[1]);
    EXPECT_GT((model_best - first.x).norm(), 0.3);
    const HardwareProposal second = hw.ask({first.x});
    EXPECT_NE(second.basis, ProposalBasis::kSimulationOptimum);
    EXPECT_GT((second.x - first.x).norm(), 1e-6);
  }
}

TEST(HardwareOptimizer, AnEnqueuedGaitThatRanIsTheFirstRolloutEvenWhenTheSimulationFoundBetter) {
  HardwareOptimizerOptions options;
  options.seed = 3;
  HardwareOptimizer hw(unit_square(), options);
  tell_bowl_with_a_lucky_rollout(hw);
  // Two queued gaits: one walked in simulation at cost 0.4, one (lower) fell: the one that walked.
  hw.tell_simulation({Eigen::Vector2d(0.3, 0.8), 0.4}, /*enqueued=*/true);
  hw.tell_simulation({Eigen::Vector2d(0.35, 0.8), 0.1, false, true}, /*enqueued=*/true);
  const HardwareProposal first = hw.ask();
  EXPECT_EQ(first.x, Eigen::Vector2d(0.3, 0.8));
  EXPECT_EQ(first.basis, ProposalBasis::kEnqueuedGait);
  ASSERT_TRUE(hw.start_point());
  EXPECT_EQ(hw.start_point()->observation, hw.simulation_observations().size() - 2);
}

TEST(HardwareOptimizer, LaterProposalsStayWithinTheMarginOfTheBestRobotCostOrAreFlagged) {
  for (HardwareStrategy strategy : {HardwareStrategy::kMultiFidelity, HardwareStrategy::kTransfer}) {
    for (CostTransform transform : {CostTransform::kNone, CostTransform::kLog}) {
      SCOPED_TRACE(to_string(strategy) + (transform == CostTransform::kLog ? " log" : " none"));
      HardwareOptimizerOptions options;
      options.strategy = strategy;
      options.cost_transform = transform;
      options.seed = 6;
      HardwareOptimizer hw(unit_square(), options);
      const Eigen::MatrixXd Xs = make_initial_design(InitialDesign::kSobol, 30, 2, 4);
      for (Eigen::Index i = 0; i < Xs.rows(); ++i) {
        const Eigen::VectorXd x = Xs.row(i).transpose();
        hw.tell_simulation({x, bowl(x) + 0.2});  // > 0: log units too
      }
      double best = std::numeric_limits<double>::infinity();
      int flagged = 0;
      for (int k = 0; k < 8; ++k) {
        const HardwareProposal p = hw.ask();
        if (k == 0) {
          EXPECT_EQ(p.basis, ProposalBasis::kSimulationOptimum);
        } else {
          // The limit is (1 + margin) times the best robot cost so far, in either unit.
          EXPECT_NEAR(p.cost_limit, (1.0 + options.safe_margin) * best, 1e-9 * best) << "proposal " << k;
          // The bound is the hardware posterior's mean + beta std, transformed back to cost units.
          const double upper = p.hardware.mean + options.safe_beta * p.hardware.std;
          EXPECT_NEAR(p.cost_bound, transform == CostTransform::kLog ? std::exp(upper) : upper, 1e-9) << k;
          if (p.within_cost_bound) {
            EXPECT_LE(p.cost_bound, p.cost_limit) << "proposal " << k;
            EXPECT_EQ(p.basis, ProposalBasis::kSafe);
          } else {
            EXPECT_GT(p.cost_bound, p.cost_limit) << "proposal " << k;
            EXPECT_EQ(p.basis, ProposalBasis::kLowestBound);
            ++flagged;
          }
        }
        const double cost = robot_bowl(p.x);
        best = std::min(best, cost);
        hw.tell_hardware({p.x, cost});
      }
      std::printf("%d of 7 later proposals flagged (no candidate within the bound), best robot cost %.4f\n", flagged,
                  best);
    }
  }
}

TEST(HardwareOptimizer, WhenNoCandidateClearsTheBoundTheLowestBoundIsProposedAndFlagged) {
  // A lucky robot rollout far below anything the model expects anywhere (the robot's bowl bottoms out at
  // 0.5), no margin and a bound of 10 standard deviations: no candidate's pessimistic cost clears it.
  HardwareOptimizerOptions options;
  options.seed = 2;
  options.safe_margin = 0.0;
  options.safe_beta = 10.0;
  HardwareOptimizer hw(unit_square(), options);
  tell_bowl(hw, [](const Eigen::VectorXd&) { return false; });
  hw.tell_hardware({Eigen::Vector2d(0.3, 0.3), 0.05});
  const HardwareProposal p = hw.ask();
  std::printf("lowest bound %.4f against the limit %.4f at (%.3f, %.3f)\n", p.cost_bound, p.cost_limit, p.x[0], p.x[1]);
  EXPECT_EQ(p.basis, ProposalBasis::kLowestBound);
  EXPECT_FALSE(p.within_cost_bound);
  EXPECT_TRUE(p.within_fall_limit);
  EXPECT_GT(p.cost_bound, p.cost_limit);
  EXPECT_NEAR(p.cost_limit, 0.05, 1e-12);  // the best robot cost, no margin
}

TEST(HardwareOptimizer, ARestoreAfterTheFirstProposalProposesWhatTheOriginalWould) {
  for (HardwareStrategy strategy : {HardwareStrategy::kMultiFidelity, HardwareStrategy::kTransfer}) {
    SCOPED_TRACE(to_string(strategy));
    HardwareOptimizerOptions options;
    options.strategy = strategy;
    options.seed = 9;
    HardwareOptimizer original(unit_square(), options);
    tell_bowl_with_a_lucky_rollout(original);
    original.tell_simulation({Eigen::Vector2d(0.6, 0.3), 0.5}, /*enqueued=*/true);
    const HardwareProposal first = original.ask();
    EXPECT_EQ(first.basis, ProposalBasis::kEnqueuedGait);
    // Killed right after the first ask (before its rollout reported): the same first point.
    {
      HardwareOptimizer restored = HardwareOptimizer::restore(
          unit_square(), options, original.simulation_observations(), original.hardware_observations(),
          hardware_model_state_from_json(nlohmann::json::parse(hardware_model_state_to_json(original.model_state()).dump())),
          original.simulation_enqueued());
      const HardwareProposal again = restored.ask();
      EXPECT_EQ(again.x, first.x);
      EXPECT_EQ(again.basis, first.basis);
      EXPECT_EQ(again.cost_bound, first.cost_bound);
    }
    original.tell_hardware({first.x, robot_bowl(first.x)});
    const std::string saved = hardware_model_state_to_json(original.model_state()).dump();
    HardwareOptimizer restored = HardwareOptimizer::restore(
        unit_square(), options, original.simulation_observations(), original.hardware_observations(),
        hardware_model_state_from_json(nlohmann::json::parse(saved)), original.simulation_enqueued());
    for (int k = 0; k < 3; ++k) {
      const HardwareProposal a = original.ask(), b = restored.ask();
      EXPECT_EQ(a.x, b.x) << "proposal " << k + 1;
      EXPECT_EQ(a.cost_bound, b.cost_bound) << "proposal " << k + 1;
      EXPECT_EQ(a.cost_limit, b.cost_limit) << "proposal " << k + 1;
      EXPECT_EQ(a.basis, b.basis) << "proposal " << k + 1;
      original.tell_hardware({a.x, robot_bowl(a.x)});
      restored.tell_hardware({b.x, robot_bowl(b.x)});
    }
    // The enqueued flags must match the observations.
    EXPECT_THROW(HardwareOptimizer::restore(unit_square(), options, original.simulation_observations(),
                                            original.hardware_observations(), original.model_state(), {true}),
                 InputError);
  }
}

TEST(HardwareOptimizer, ANegativeSafeMarginOrBetaIsRefusedNamingTheField) {
  for (const auto& [margin, beta, field] : std::vector<std::tuple<double, double, std::string>>{
           {-0.1, 2.0, "safe_margin"}, {0.1, -1.0, "safe_beta"}, {std::nan(""), 2.0, "safe_margin"}}) {
    HardwareOptimizerOptions options;
    options.safe_margin = margin;
    options.safe_beta = beta;
    try {
      HardwareOptimizer hw(unit_square(), options);
      ADD_FAILURE() << field << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
}

// The robot of the regret comparison: 0.8 hartmann3 plus a smooth gap that penalises high x3 and rewards
// high x1 (so the robot's optimum is not the simulation's: hartmann3's minimum sits at x3 = 0.85).
double robot_hartmann(const Eigen::VectorXd& x) {
  static const TestFunction h3 = test_function("hartmann3");
  return 0.8 * h3.f(x) + 0.3 + 0.9 * x[2] - 0.4 * x[0];
}

// The robot's minimum over the unit cube: a 61^3 grid, then Nelder-Mead from its best point.
double robot_hartmann_minimum() {
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector3d arg;
  for (int i = 0; i <= 60; ++i)
    for (int j = 0; j <= 60; ++j)
      for (int k = 0; k <= 60; ++k) {
        const Eigen::Vector3d x(i / 60.0, j / 60.0, k / 60.0);
        const double v = robot_hartmann(x);
        if (v < best) best = v, arg = x;
      }
  for (double h = 1.0 / 120; h > 1e-7; h /= 2) {  // pattern search around the grid's best
    bool moved = true;
    while (moved) {
      moved = false;
      for (int d = 0; d < 3; ++d)
        for (double s : {-h, h}) {
          Eigen::Vector3d x = arg;
          x[d] = std::clamp(x[d] + s, 0.0, 1.0);
          if (const double v = robot_hartmann(x); v < best) best = v, arg = x, moved = true;
        }
    }
  }
  return best;
}

struct Regrets {
  double multi_fidelity = 0.0, transfer = 0.0, hardware_only = 0.0, simulated_optimum = 0.0;
  double rho = 0.0;
};

// One seed: 40 simulated rollouts proposed by the study's BayesianOptimizer, then 15 robot rollouts by
// each strategy; against 15 robot rollouts of plain BO (5 of them the initial design). Regret: the best
// robot cost found minus the robot's minimum.
Regrets regrets(std::uint64_t seed, double robot_minimum) {
  constexpr int kSimulated = 40, kHardware = 15;
  const TestFunction h3 = test_function("hartmann3");
  Regrets r;
  OptimizerOptions sim_options;
  sim_options.initial_points = 10;
  sim_options.seed = seed;
  BayesianOptimizer sim(h3.space, sim_options);
  for (int i = 0; i < kSimulated; ++i) {
    const Eigen::VectorXd x = sim.ask(1).front();
    sim.tell(x, h3.f(x));
  }
  r.simulated_optimum = robot_hartmann(sim.best()->x) - robot_minimum;
  for (HardwareStrategy strategy : {HardwareStrategy::kMultiFidelity, HardwareStrategy::kTransfer}) {
    HardwareOptimizerOptions options;
    options.strategy = strategy;
    options.seed = seed;
    HardwareOptimizer hw(h3.space, options);
    for (const Observation& o : sim.observations()) hw.tell_simulation(o);
    double best = std::numeric_limits<double>::infinity();
    for (int i = 0; i < kHardware; ++i) {
      const Eigen::VectorXd x = hw.ask().x;
      best = std::min(best, robot_hartmann(x));
      hw.tell_hardware({x, robot_hartmann(x)});
    }
    (strategy == HardwareStrategy::kTransfer ? r.transfer : r.multi_fidelity) = best - robot_minimum;
    if (strategy == HardwareStrategy::kMultiFidelity) r.rho = hw.multi_fidelity_model()->rho();
  }
  OptimizerOptions hw_options;
  hw_options.initial_points = 5;
  hw_options.budget = kHardware;
  hw_options.seed = seed;
  BayesianOptimizer hardware_only(h3.space, hw_options);
  for (int i = 0; i < kHardware; ++i) {
    const Eigen::VectorXd x = hardware_only.ask(1).front();
    hardware_only.tell(x, robot_hartmann(x));
  }
  r.hardware_only = hardware_only.best()->y - robot_minimum;
  return r;
}

TEST(HardwareOptimizer, WithFifteenRobotRolloutsMultiFidelityBeatsHardwareOnlyBOOnEverySeed) {
  const double minimum = robot_hartmann_minimum();
  std::printf("robot minimum %.5f\nseed  multi_fidelity  transfer  hardware_only  simulated_optimum  rho\n", minimum);
  double sum_mf = 0.0, sum_hw = 0.0;
  for (std::uint64_t seed : {1, 2, 3, 4, 5}) {
    const Regrets r = regrets(seed, minimum);
    std::printf("%4llu  %14.4f  %8.4f  %13.4f  %17.4f  %.3f\n", static_cast<unsigned long long>(seed), r.multi_fidelity,
                r.transfer, r.hardware_only, r.simulated_optimum, r.rho);
    EXPECT_LT(r.multi_fidelity, r.hardware_only) << "seed " << seed;
    sum_mf += r.multi_fidelity;
    sum_hw += r.hardware_only;
  }
  EXPECT_LT(sum_mf, 0.5 * sum_hw);
}

}  // namespace
}  // namespace cpgmatch::bo

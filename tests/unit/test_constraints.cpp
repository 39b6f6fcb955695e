// Parameter constraints (issue 24): the expression language, its errors with their positions, the study
// file's `constraints` key, and an optimizer whose design and proposals never leave the feasible region.
#include <cmath>

#include <gtest/gtest.h>

#include "cpgmatch/bo/constraints.hpp"
#include "cpgmatch/bo/optimizer.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::bo {
namespace {

const std::set<std::string> kNames = {"hip_offset", "hip_amplitude", "overswing", "x", "y"};

Dimension dim(const std::string& name, double low, double high) { return Dimension{name, low, high, false, ""}; }
const SearchSpace kXY({dim("x", 0.0, 1.0), dim("y", 0.0, 1.0)});

double slack(const std::string& text, const std::map<std::string, double>& values) {
  return Constraint::parse(text, kNames).slack(values);
}

// The position a syntax error reports (0: none).
int error_position(const std::string& text) {
  try {
    (void)Constraint::parse(text, kNames);
  } catch (const ConstraintSyntaxError& e) {
    return e.position();
  }
  return 0;
}

TEST(ConstraintExpression, TheEnvelopeEvaluatesWithUsualPrecedence) {
  const std::map<std::string, double> gait = {{"hip_offset", 0.3}, {"hip_amplitude", 0.6}, {"overswing", 0.5}};
  // 0.3 + 0.6 * 1.5 = 1.2: 0.13 inside the 1.33 rad envelope.
  EXPECT_NEAR(slack("hip_offset + hip_amplitude * (1 + overswing) <= 1.33", gait), 0.13, 1e-12);
  // Without the parentheses * binds first: 0.3 + 0.6 + 0.5 = 1.4, outside.
  EXPECT_NEAR(slack("hip_offset + hip_amplitude * 1 + overswing <= 1.33", gait), -0.07, 1e-12);
  // >= turns the slack around; unary minus, division, left-associative subtraction.
  EXPECT_NEAR(slack("hip_offset - hip_amplitude * (1 + overswing) >= -1.33", gait), 0.73, 1e-12);
  EXPECT_NEAR(slack("-x / 2 - 1 - 1 >= -3", {{"x", 4.0}}), -1.0, 1e-12);  // -4 against -3
  EXPECT_NEAR(slack("1e-1 * x <= .5", {{"x", 2.0}}), 0.3, 1e-12);
  // A division by zero is never satisfied (NaN or inf slack).
  EXPECT_FALSE(slack("x / y <= 1", {{"x", 0.0}, {"y", 0.0}}) >= 0.0);
}

TEST(ConstraintExpression, ErrorsSayWhatIsWrongAndWhere) {
  try {
    (void)Constraint::parse("hip_offset + hip_amplitud * 2 <= 1", kNames);
    FAIL() << "an unknown name parsed";
  } catch (const ConstraintSyntaxError& e) {
    EXPECT_EQ(e.position(), 14);
    EXPECT_NE(std::string(e.what()).find("unknown parameter 'hip_amplitud'"), std::string::npos) << e.what();
  }
  EXPECT_EQ(error_position("x + <= 1"), 5);       // an operand missing
  EXPECT_EQ(error_position("x + 1"), 6);          // no comparison before the end
  EXPECT_EQ(error_position("x < 1"), 3);          // strict comparisons are not offered
  EXPECT_EQ(error_position("x <= 1 <= 2"), 8);    // one comparison per constraint
  EXPECT_EQ(error_position("(x + 1 <= 2"), 8);    // unclosed parenthesis
  EXPECT_EQ(error_position("x ^ 2 <= 1"), 3);
  EXPECT_EQ(error_position("x <= 1 y"), 8);
  EXPECT_EQ(error_position("x * (y + 1) >= 0.5"), 0);
}

TEST(ConstraintExpression, BoundToASpaceFixedAndOtherValuesAreConstants) {
  const SearchSpace space({dim("hip_offset", -0.35, 0.35), dim("hip_amplitude", 0.05, 0.65)}, {{"overswing", 0.5}});
  const ParameterConstraints c({Constraint::parse("hip_offset + hip_amplitude * (1 + overswing) <= 1.33", kNames),
                                Constraint::parse("x * hip_amplitude <= 1", kNames)},
                               space, {{"x", 2.0}});
  EXPECT_TRUE(c.feasible(Eigen::Vector2d(0.3, 0.5)));                       // 1.05, and 2 * 0.5 = 1
  EXPECT_EQ(c.violated(Eigen::Vector2d(0.35, 0.65)).value_or(""),           // 1.325 in, but 2 * 0.65 > 1
            "x * hip_amplitude <= 1");
  EXPECT_THROW(ParameterConstraints({Constraint::parse("y <= 1", kNames)}, space, {}), InputError);
}

// Every point an optimizer proposes, initial design and model alike, one at a time and in batches.
void expect_feasible_study(InitialDesign design, std::uint64_t seed) {
  const SearchSpace& space = kXY;
  OptimizerOptions o;
  o.seed = seed;
  o.initial_points = 6;
  o.initial_design = design;
  o.acquisition_candidates = 300;
  // The unconstrained minimum (0.7, 0.7) is outside: the best feasible points lie on x + y = 0.8.
  o.constraints = std::make_shared<const ParameterConstraints>(
      std::vector<Constraint>{Constraint::parse("x + y <= 0.8", kNames), Constraint::parse("y >= 0.1", kNames)}, space,
      std::map<std::string, double>{});
  BayesianOptimizer opt(space, o);
  double best = 1e9;
  Eigen::VectorXd best_x;
  for (int round = 0; round < 12; ++round) {
    const auto batch = opt.ask(round % 3 == 0 ? 3 : 1, {});
    for (const auto& x : batch) {
      ASSERT_TRUE(o.constraints->feasible(x)) << "seed " << seed << " round " << round << ": (" << x[0] << ", " << x[1] << ")";
      const double f = (x[0] - 0.7) * (x[0] - 0.7) + (x[1] - 0.7) * (x[1] - 0.7);
      opt.tell(x, f);
      if (f < best) {
        best = f;
        best_x = x;
      }
    }
  }
  // It searched along the boundary: the best point is close to the constraint line, not merely feasible.
  EXPECT_GT(best_x[0] + best_x[1], 0.7) << "seed " << seed;
}

TEST(ConstrainedOptimizer, TheDesignAndEveryProposalSatisfyTheConstraintsOnSeveralSeeds) {
  for (const std::uint64_t seed : {0u, 1u, 2u, 3u, 4u}) expect_feasible_study(InitialDesign::kRandom, seed);
  for (const std::uint64_t seed : {0u, 7u}) expect_feasible_study(InitialDesign::kSobol, seed);
  for (const std::uint64_t seed : {0u, 7u}) expect_feasible_study(InitialDesign::kLatinHypercube, seed);
}

TEST(ConstrainedOptimizer, ConstraintsThatLeaveNothingAreRefusedNotSearchedForever) {
  const SearchSpace& space = kXY;
  OptimizerOptions o;
  o.constraints = std::make_shared<const ParameterConstraints>(
      std::vector<Constraint>{Constraint::parse("x + y >= 3", kNames)}, space, std::map<std::string, double>{});
  EXPECT_THROW(BayesianOptimizer(space, o), InputError);
}

}  // namespace
}  // namespace cpgmatch::bo

namespace cpgmatch::study {
namespace {

std::string load_error(const std::string& yaml) {
  try {
    (void)load_study_config_text(yaml, "s.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(StudyConstraints, TheStudyFileNamesTheLineAndThePositionOfABadConstraint) {
  const std::string error = load_error(
      "name: c\nconstraints:\n  - \"hip_offset <= 0.3\"\n  - \"hip_offset + hip_amplitud * (1 + overswing) <= 1.33\"\n");
  EXPECT_NE(error.find("s.yaml:4"), std::string::npos) << error;
  EXPECT_NE(error.find("constraints[1]"), std::string::npos) << error;
  EXPECT_NE(error.find("unknown parameter 'hip_amplitud'"), std::string::npos) << error;
  EXPECT_NE(error.find("position 14"), std::string::npos) << error;
  EXPECT_NE(load_error("name: c\nconstraints: [\"hip_offset < 1\"]\n").find("position 12"), std::string::npos);
  EXPECT_NE(load_error("name: c\nconstraints: \"hip_offset <= 1\"\n").find("must be a list"), std::string::npos);
  // Fixed in the paper's space: true or false for every trial, so refused as a mistake.
  EXPECT_NE(load_error("name: c\nconstraints: [\"frequency <= 2\"]\n").find("no searched parameter"), std::string::npos);
  EXPECT_EQ(load_error("name: c\nconstraints: [\"hip_offset + hip_amplitude * (1 + overswing) <= 1.33\"]\n"), "");
}

TEST(StudyConstraints, ConstraintsArePartOfTheSpecAndBoundWithTheStudysValues) {
  const SpecDefaults shipped = SpecDefaults::shipped();
  const StudySpec plain = StudySpec::resolve("name: c\n", "c.yaml", shipped);
  // knee_amplitude is fixed (0.5236 rad) in the paper's space: it takes that value in the expression.
  const StudySpec constrained =
      StudySpec::resolve("name: c\nconstraints: [\"hip_amplitude + knee_amplitude <= 1.0\"]\n", "c.yaml", shipped);
  EXPECT_NE(plain.sha256(), constrained.sha256());
  EXPECT_EQ(plain.config().optimizer.constraints, nullptr);
  const auto& bound = constrained.config().optimizer.constraints;
  ASSERT_NE(bound, nullptr);
  const bo::SearchSpace& space = constrained.config().space;
  Eigen::VectorXd x = space.from_unit(Eigen::VectorXd::Constant(space.size(), 0.5));
  x[space.index_of("hip_amplitude")] = 0.47;
  EXPECT_TRUE(bound->feasible(x));  // 0.47 + 0.5236 <= 1
  x[space.index_of("hip_amplitude")] = 0.48;
  EXPECT_FALSE(bound->feasible(x));
  // The stored spec reloads with the same binding (a restart), and enqueue file names stay out of it.
  const StudySpec reloaded = StudySpec::from_json_text(constrained.canonical_json(), "stored");
  ASSERT_NE(reloaded.config().optimizer.constraints, nullptr);
  EXPECT_FALSE(reloaded.config().optimizer.constraints->feasible(x));
  const StudySpec with_enqueue = StudySpec::resolve(
      "name: c\nconstraints: [\"hip_amplitude + knee_amplitude <= 1.0\"]\nenqueue: [a.yaml]\n", "c.yaml", shipped);
  EXPECT_EQ(with_enqueue.sha256(), constrained.sha256());
}

}  // namespace
}  // namespace cpgmatch::study

// The emergency-stop latch alone (no DDS, no bus): which commands concern a robot, that a stop holds
// until a release, and that the first reason is the one kept.
#include <gtest/gtest.h>

#include "cpgmatch/robot/estop_latch.hpp"

namespace cpgmatch::robot {
namespace {

TEST(EstopLatch, AStopForThisRobotLatchesUntilReleased) {
  EstopLatch latch("morti");
  EXPECT_FALSE(latch.reason());
  EXPECT_EQ(latch.apply({"morti", "hand on the e-stop", false}), StopOutcome::kLatched);
  ASSERT_TRUE(latch.reason());
  EXPECT_EQ(*latch.reason(), "hand on the e-stop");
  // Nothing but a release lifts it: a later stop does not, and the first reason stays.
  EXPECT_EQ(latch.apply({"morti", "second press", false}), StopOutcome::kAlreadyLatched);
  EXPECT_EQ(*latch.reason(), "hand on the e-stop");
  EXPECT_EQ(latch.apply({"morti", "", true}), StopOutcome::kReleased);
  EXPECT_FALSE(latch.reason());
  EXPECT_EQ(latch.apply({"morti", "", true}), StopOutcome::kNothingToRelease);
}

TEST(EstopLatch, OtherRobotsCommandsChangeNothing) {
  EstopLatch latch("morti");
  EXPECT_EQ(latch.apply({"cheetah", "not you", false}), StopOutcome::kNotForThisRobot);
  EXPECT_FALSE(latch.reason());
  EXPECT_EQ(latch.apply({"", "empty target is nobody", false}), StopOutcome::kNotForThisRobot);
  EXPECT_FALSE(latch.reason());
  ASSERT_EQ(latch.apply({"morti", "mine", false}), StopOutcome::kLatched);
  // Another robot's release must not release this one.
  EXPECT_EQ(latch.apply({"cheetah", "", true}), StopOutcome::kNotForThisRobot);
  EXPECT_EQ(*latch.reason(), "mine");
  // A prefix of the id is another robot.
  EXPECT_EQ(latch.apply({"mort", "", true}), StopOutcome::kNotForThisRobot);
  EXPECT_TRUE(latch.reason());
}

TEST(EstopLatch, AllStopsAndReleasesEveryRobot) {
  EstopLatch a("morti"), b("cheetah");
  for (EstopLatch* l : {&a, &b}) EXPECT_EQ(l->apply({kAllRobots, "fire alarm", false}), StopOutcome::kLatched);
  EXPECT_EQ(*b.reason(), "fire alarm");
  EXPECT_EQ(a.apply({kAllRobots, "", true}), StopOutcome::kReleased);
  EXPECT_FALSE(a.reason());
  EXPECT_TRUE(b.reason());  // released separately
}

TEST(EstopLatch, AStopWithoutReasonSaysSo) {
  EstopLatch latch("morti");
  ASSERT_EQ(latch.apply({"morti", "", false}), StopOutcome::kLatched);
  EXPECT_EQ(*latch.reason(), "no reason given");
}

}  // namespace
}  // namespace cpgmatch::robot

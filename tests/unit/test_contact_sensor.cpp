// The FootTile-like contact sensor: hysteresis, debouncing, latency and validation.
#include <gtest/gtest.h>

#include "cpgmatch/contact_sensor.hpp"
#include "cpgmatch/errors.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch {
namespace {

// Polls one leg (FL) at 250 Hz through a force profile; returns the reported contact per poll.
std::vector<bool> poll_all(ContactSensor& sensor, const std::vector<double>& force_n) {
  std::vector<bool> out;
  for (std::size_t i = 0; i < force_n.size(); ++i) {
    out.push_back(sensor.poll(i * 0.004, {force_n[i], 10.0, 10.0, 10.0})[kFrontLeft]);
  }
  return out;
}

int changes(const std::vector<bool>& v) {
  int n = 0;
  for (std::size_t i = 1; i < v.size(); ++i) n += v[i] != v[i - 1];
  return n;
}

TEST(ContactSensor, AForceHoveringAroundTheThresholdDoesNotFlicker) {
  // Standing (10 N), lift-off, then 20 polls alternating 1.5 / 2.5 N around the 2 N threshold, then a
  // clean touchdown. A single threshold would report ~20 changes; hysteresis (release 1 N) reports none.
  std::vector<double> f(10, 10.0);
  for (int i = 0; i < 10; ++i) f.push_back(0.0);
  for (int i = 0; i < 20; ++i) f.push_back(i % 2 ? 2.5 : 1.5);
  for (int i = 0; i < 10; ++i) f.push_back(10.0);
  ContactSensorConfig cfg;
  ContactSensor sensor(cfg, 1, test::kNumLegs);
  const auto seen = poll_all(sensor, f);
  EXPECT_EQ(changes(seen), 2);  // one lift-off, one touchdown (made at the first 2.5 N that holds)

  ContactSensorConfig plain = cfg;
  plain.release_threshold_n = plain.threshold_n;
  plain.min_stable_s = 0.0;
  ContactSensor naive(plain, 1, test::kNumLegs);
  EXPECT_GT(changes(poll_all(naive, f)), 15);
}

TEST(ContactSensor, AOnePollGlitchIsIgnoredAndARealChangeIsReportedAfterTheMinimumDuration) {
  std::vector<double> f(10, 10.0);
  f.push_back(0.0);  // one-poll dropout (4 ms < 8 ms)
  for (int i = 0; i < 10; ++i) f.push_back(10.0);
  for (int i = 0; i < 10; ++i) f.push_back(0.0);  // real lift-off at poll 21
  ContactSensor sensor({}, 1, test::kNumLegs);
  const auto seen = poll_all(sensor, f);
  for (int i = 0; i < 21; ++i) EXPECT_TRUE(seen[i]) << "poll " << i;
  EXPECT_TRUE(seen[22]);   // 4 ms after the change: not yet
  EXPECT_FALSE(seen[23]);  // 8 ms after: reported
}

TEST(ContactSensor, LatencyDelaysTheReportedContact) {
  ContactSensorConfig cfg;
  cfg.min_stable_s = 0.0;
  cfg.latency_s = 0.012;  // three polls
  std::vector<double> f(5, 10.0);
  for (int i = 0; i < 10; ++i) f.push_back(0.0);
  ContactSensor sensor(cfg, 1, test::kNumLegs);
  const auto seen = poll_all(sensor, f);
  EXPECT_TRUE(seen[7]);
  EXPECT_FALSE(seen[8]);
}

TEST(ContactSensor, BadConfigNamesTheField) {
  ContactSensorConfig cfg;
  cfg.release_threshold_n = 3.0;  // above the threshold
  try {
    validate(cfg);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("contact_sensor.release_threshold_n"), std::string::npos) << e.what();
  }
  cfg = {};
  cfg.min_stable_s = std::nan("");
  EXPECT_THROW(validate(cfg), InputError);
}

}  // namespace
}  // namespace cpgmatch

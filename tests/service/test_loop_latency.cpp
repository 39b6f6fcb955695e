// LatencyRecorder (services/optimizer_service/loop_latency.hpp): bounded memory, unbiased percentiles.
#include <gtest/gtest.h>

#include <string>

#include "loop_latency.hpp"

namespace cpgmatch::service {
namespace {

// "p50 12.34 ms" -> 12.34
double field(const std::string& summary, const std::string& name) {
  const auto at = summary.find(name + " ");
  EXPECT_NE(at, std::string::npos) << summary;
  return std::stod(summary.substr(at + name.size() + 1));
}

TEST(LatencyRecorderTest, PercentilesAreExactWhileEverySampleFits) {
  LatencyRecorder r;
  for (int i = 1; i <= 1000; ++i) r.add(i * 1e-3);  // 1..1000 ms
  const std::string s = r.summary();
  EXPECT_EQ(s.rfind("n 1000,", 0), 0u) << s;
  EXPECT_DOUBLE_EQ(field(s, "p50"), 501.0);
  EXPECT_DOUBLE_EQ(field(s, "p99"), 991.0);
  EXPECT_DOUBLE_EQ(field(s, "max"), 1000.0);
}

TEST(LatencyRecorderTest, ALongRunKeepsAUniformSampleOfTheWholeRunNotItsStart) {
  // Ten reservoirs' worth: the first tenth is fast (1 ms), the rest slow (100 ms). Keeping only the
  // first samples would report p50 = 1 ms; a uniform sample reports the slow majority.
  LatencyRecorder r;
  const std::size_t n = 10 * LatencyRecorder::kMaxSamples;
  for (std::size_t i = 0; i < n; ++i) r.add(i < n / 10 ? 1e-3 : 100e-3);
  const std::string s = r.summary();
  EXPECT_EQ(s.rfind("n " + std::to_string(n) + ",", 0), 0u) << s;
  EXPECT_DOUBLE_EQ(field(s, "p50"), 100.0);
  EXPECT_DOUBLE_EQ(field(s, "max"), 100.0);
}

TEST(LatencyRecorderTest, AnEmptyRecorderSaysSo) { EXPECT_EQ(LatencyRecorder{}.summary(), "n 0"); }

}  // namespace
}  // namespace cpgmatch::service

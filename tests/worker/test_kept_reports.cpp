// Which reports a worker's writer keeps (workers/worker_core/kept_reports.hpp): until the optimizer
// acknowledges them by disposing the candidate, and never more than the limit. No DDS traffic.
#include <gtest/gtest.h>

#include "cpgmatch/worker/kept_reports.hpp"

namespace cpgmatch::worker {
namespace {

domain::AttemptId report(int trial, std::uint64_t store = 77, int study = 1, int attempt = 0) {
  return domain::AttemptId{store, study, trial, attempt};
}

domain::AttemptId key(int trial, std::uint64_t store = 77, int study = 1) {
  return domain::AttemptId{store, study, trial, 0};  // a dispose carries the key fields only
}

TEST(KeptReports, AReportIsKeptUntilItsCandidateIsDisposed) {
  KeptReports kept;
  EXPECT_TRUE(kept.keep(report(1)).empty());
  EXPECT_TRUE(kept.keep(report(2)).empty());
  EXPECT_EQ(kept.size(), 2u);
  const auto released = kept.acknowledge(key(1));
  ASSERT_TRUE(released.has_value());
  EXPECT_EQ(released->trial_id, 1);
  EXPECT_EQ(kept.size(), 1u);
  EXPECT_FALSE(kept.acknowledge(key(1)).has_value());  // a second dispose releases nothing
}

TEST(KeptReports, OnlyTheDisposedCandidatesOwnStoreAndStudyMatch) {
  KeptReports kept;
  kept.keep(report(1, 77, 1));
  EXPECT_FALSE(kept.acknowledge(key(1, 78, 1)).has_value());  // another store's trial 1
  EXPECT_FALSE(kept.acknowledge(key(1, 77, 2)).has_value());  // another study's trial 1
  EXPECT_FALSE(kept.acknowledge(key(2, 77, 1)).has_value());  // a candidate this worker never reported
  EXPECT_EQ(kept.size(), 1u);
  EXPECT_TRUE(kept.acknowledge(key(1, 77, 1)).has_value());
}

TEST(KeptReports, BeyondTheLimitTheOldestUnacknowledgedIsReleased) {
  KeptReports kept(3);
  for (std::uint32_t t = 1; t <= 3; ++t) EXPECT_TRUE(kept.keep(report(t)).empty());
  ASSERT_TRUE(kept.acknowledge(key(1)).has_value());
  EXPECT_TRUE(kept.keep(report(4)).empty());  // 2, 3, 4: at the limit, nothing to release
  const auto released = kept.keep(report(5));
  ASSERT_EQ(released.size(), 1u);
  EXPECT_EQ(released[0].trial_id, 2);  // the oldest still kept, not the acknowledged 1
  EXPECT_EQ(kept.size(), 3u);
  EXPECT_FALSE(kept.acknowledge(key(2)).has_value());
}

TEST(KeptReports, StaysBoundedOverManyReportsWithoutAcknowledgement) {
  KeptReports kept(16);
  std::size_t released = 0;
  for (std::uint32_t t = 1; t <= 1000; ++t) released += kept.keep(report(t)).size();
  EXPECT_EQ(kept.size(), 16u);
  EXPECT_EQ(released, 1000u - 16u);
  EXPECT_TRUE(kept.acknowledge(key(1000)).has_value());
  EXPECT_FALSE(kept.acknowledge(key(984)).has_value());  // released long ago
}

TEST(KeptReports, AReissuedTrialsNewerReportReplacesTheOlder) {
  KeptReports kept;
  kept.keep(report(1, 77, 1, 0));
  kept.keep(report(1, 77, 1, 1));  // the same instance: the writer holds one sample per key
  EXPECT_EQ(kept.size(), 1u);
  const auto released = kept.acknowledge(key(1));
  ASSERT_TRUE(released.has_value());
  EXPECT_EQ(released->attempt, 1u);
}

}  // namespace
}  // namespace cpgmatch::worker

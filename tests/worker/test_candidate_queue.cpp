// The candidate queue every worker shares (workers/worker_core): which candidates run, in what order,
// what a duplicate delivery is, and how a shutdown hands queued work back. No DDS traffic.
#include <chrono>
#include <future>

#include <gtest/gtest.h>

#include "cpgmatch/worker/candidate_queue.hpp"

namespace cpgmatch::worker {
namespace {

domain::Candidate candidate(int trial, int attempt = 0, const std::string& worker = "w1", std::uint64_t store = 77,
                            int study = 1) {
  domain::Candidate c;
  c.id = domain::AttemptId{store, study, trial, attempt};
  c.worker_id = worker;
  return c;
}

using Offer = CandidateQueue::Offer;

TEST(CandidateQueue, AcceptsOnlyCandidatesAddressedToThisWorker) {
  CandidateQueue q("w1");
  EXPECT_EQ(q.offer(candidate(1, 0, "w2")), Offer::kNotOurs);
  EXPECT_EQ(q.offer(candidate(1, 0, "w10")), Offer::kNotOurs);  // no prefix matching
  EXPECT_EQ(q.load().queued, 0u);
  EXPECT_EQ(q.offer(candidate(1, 0, "w1")), Offer::kQueued);
  EXPECT_EQ(q.load().queued, 1u);
}

TEST(CandidateQueue, TheSameIssueDeliveredTwiceWhileQueuedRunsOnce) {
  CandidateQueue q("w1");
  EXPECT_EQ(q.offer(candidate(1)), Offer::kQueued);
  EXPECT_EQ(q.offer(candidate(1)), Offer::kDuplicate);
  EXPECT_EQ(q.load().queued, 1u);
}

TEST(CandidateQueue, TheSameIssueDeliveredWhileRunningIsDroppedAndAcceptedAgainAfterItsReport) {
  CandidateQueue q("w1");
  ASSERT_EQ(q.offer(candidate(1)), Offer::kQueued);
  const auto running = q.take();
  ASSERT_TRUE(running.has_value());
  EXPECT_EQ(q.offer(candidate(1)), Offer::kDuplicate);  // a robot must not walk the same issue twice at once
  EXPECT_EQ(q.load().queued, 0u);
  q.finish(*running);
  // Remembering only what is queued or running keeps the memory bounded; the optimizer counts a trial once.
  EXPECT_EQ(q.offer(candidate(1)), Offer::kQueued);
}

TEST(CandidateQueue, AReissueOrAnotherStoresTrialIsNewWork) {
  CandidateQueue q("w1");
  ASSERT_EQ(q.offer(candidate(1, 0)), Offer::kQueued);
  EXPECT_EQ(q.offer(candidate(1, 1)), Offer::kQueued);                // attempt 1: re-issued after a lost report
  EXPECT_EQ(q.offer(candidate(1, 0, "w1", 78)), Offer::kQueued);      // same ids, another store
  EXPECT_EQ(q.offer(candidate(1, 0, "w1", 77, 2)), Offer::kQueued);   // same trial id, another study
  EXPECT_EQ(q.load().queued, 4u);
}

TEST(CandidateQueue, TakesInArrivalOrderAndCountsBusyAndCompleted) {
  CandidateQueue q("w1");
  for (std::uint32_t t : {5u, 3u, 9u}) ASSERT_EQ(q.offer(candidate(t)), Offer::kQueued);
  const auto a = q.take();
  const auto b = q.take();
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->id.trial_id, 5);
  EXPECT_EQ(b->id.trial_id, 3);
  EXPECT_EQ(q.load().busy, 2u);
  EXPECT_EQ(q.load().queued, 1u);
  q.finish(*a);
  EXPECT_EQ(q.load().busy, 1u);
  EXPECT_EQ(q.load().completed, 1u);
  const auto c = q.take();
  ASSERT_TRUE(c);
  EXPECT_EQ(c->id.trial_id, 9);
  q.finish(*b);
  q.finish(*c);
  EXPECT_EQ(q.load().busy, 0u);
  EXPECT_EQ(q.load().completed, 3u);
}

TEST(CandidateQueue, TakeWaitsForAnOffer) {
  CandidateQueue q("w1");
  auto taken = std::async(std::launch::async, [&] { return q.take(); });
  EXPECT_EQ(taken.wait_for(std::chrono::milliseconds(100)), std::future_status::timeout) << "take() did not wait";
  ASSERT_EQ(q.offer(candidate(4)), Offer::kQueued);
  ASSERT_EQ(taken.wait_for(std::chrono::seconds(5)), std::future_status::ready);
  const auto c = taken.get();
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(c->id.trial_id, 4);
}

TEST(CandidateQueue, DrainWakesAWaitingTaker) {
  CandidateQueue q("w1");
  auto taken = std::async(std::launch::async, [&] { return q.take(); });
  ASSERT_EQ(taken.wait_for(std::chrono::milliseconds(100)), std::future_status::timeout);
  EXPECT_EQ(q.drain(), 0u);
  ASSERT_EQ(taken.wait_for(std::chrono::seconds(5)), std::future_status::ready) << "drain() did not wake the taker";
  EXPECT_FALSE(taken.get().has_value());
}

TEST(CandidateQueue, DrainHandsBackTheQueuedRefusesNewWorkAndLetsRunningRolloutsFinish) {
  CandidateQueue q("w1");
  ASSERT_EQ(q.offer(candidate(1)), Offer::kQueued);
  const auto running = q.take();
  ASSERT_TRUE(running);
  ASSERT_EQ(q.offer(candidate(2)), Offer::kQueued);
  ASSERT_EQ(q.offer(candidate(3)), Offer::kQueued);
  EXPECT_EQ(q.drain(), 2u);  // the optimizer re-issues them once this worker has left
  EXPECT_EQ(q.load().queued, 0u);
  EXPECT_FALSE(q.take().has_value());
  EXPECT_EQ(q.offer(candidate(4)), Offer::kDraining);
  q.finish(*running);
  EXPECT_EQ(q.load().busy, 0u);
  EXPECT_EQ(q.load().completed, 1u);
}

TEST(CandidateQueue, DrainReturnsHowManyWereQueued) {
  CandidateQueue q("w1");
  for (std::uint32_t t = 1; t <= 3; ++t) ASSERT_EQ(q.offer(candidate(t)), Offer::kQueued);
  EXPECT_EQ(q.drain(), 3u);
  EXPECT_EQ(q.load().queued, 0u);
  EXPECT_FALSE(q.take().has_value());
}

}  // namespace
}  // namespace cpgmatch::worker

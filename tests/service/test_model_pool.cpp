// ModelPool: the optimizer service's model threads (model_pool.hpp).
#include <pthread.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "cpgmatch/service/model_pool.hpp"

namespace cpgmatch::service {
namespace {

int this_threads_nice() { return ::getpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid))); }

TEST(ModelPoolTest, JobsOfOneKeyRunOneAtATimeInSubmissionOrder) {
  ModelPool pool(3);
  std::mutex mutex;
  std::vector<int> order;
  std::atomic<int> running{0}, most_at_once{0};
  for (int i = 0; i < 12; ++i) {
    pool.submit(7, [&, i]() -> ModelPool::Completion {
      const int now = ++running;
      int seen = most_at_once.load();
      while (now > seen && !most_at_once.compare_exchange_weak(seen, now)) {
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      {
        std::lock_guard<std::mutex> lock(mutex);
        order.push_back(i);
      }
      --running;
      return [] {};
    });
  }
  pool.wait_until_finished();
  EXPECT_EQ(pool.run_finished(), 12);
  EXPECT_EQ(most_at_once.load(), 1);
  std::vector<int> expected;
  for (int i = 0; i < 12; ++i) expected.push_back(i);
  EXPECT_EQ(order, expected);
}

TEST(ModelPoolTest, JobsOfDifferentKeysRunInParallel) {
  ModelPool pool(2);
  std::atomic<int> arrived{0};
  std::atomic<bool> both_seen{false};
  for (std::uint64_t key = 1; key <= 2; ++key) {
    pool.submit(key, [&]() -> ModelPool::Completion {
      ++arrived;
      // Each job waits (bounded) for the other: only possible if both run at once.
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
      while (arrived.load() < 2 && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
      if (arrived.load() == 2) both_seen = true;
      return [] {};
    });
  }
  pool.wait_until_finished();
  EXPECT_TRUE(both_seen.load());
  EXPECT_EQ(pool.run_finished(), 2);
}

TEST(ModelPoolTest, AJobsExceptionReachesTheThreadThatRunsCompletionsAndThePoolGoesOn) {
  ModelPool pool(1);
  pool.submit(1, []() -> ModelPool::Completion { throw std::runtime_error("GP not positive definite"); });
  pool.wait_until_finished();
  EXPECT_THROW(pool.run_finished(), std::runtime_error);
  bool ran = false;
  pool.submit(1, [&]() -> ModelPool::Completion { return [&] { ran = true; }; });
  pool.wait_until_finished();
  EXPECT_EQ(pool.run_finished(), 1);
  EXPECT_TRUE(ran);
  EXPECT_EQ(pool.outstanding(), 0);
}

TEST(ModelPoolTest, PoolThreadsAreNamedAndRunTenNiceLevelsBelowTheirCreator) {
  const int caller_nice = this_threads_nice();
  ModelPool pool(1);
  int job_nice = 0;
  char name[32] = {};
  pool.submit(1, [&]() -> ModelPool::Completion {
    job_nice = this_threads_nice();
    ::pthread_getname_np(::pthread_self(), name, sizeof(name));
    return [] {};
  });
  pool.wait_until_finished();
  pool.run_finished();
  // +10, capped at 19 (a caller already at nice >= 9 cannot go lower in priority than 19).
  EXPECT_EQ(job_nice, std::min(caller_nice + 10, 19));
  EXPECT_EQ(std::string(name), "cpgmatch-model");
}

}  // namespace
}  // namespace cpgmatch::service

#include "cpgmatch/service/model_pool.hpp"

#include <pthread.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <exception>

namespace cpgmatch::service {
namespace {

// A failing job must not take a pool thread down: its exception is handed to the event thread, which
// sees it when it runs the job's completion.
ModelPool::Completion run_catching(const ModelPool::Work& work) {
  try {
    return work();
  } catch (...) {
    return [error = std::current_exception()] { std::rethrow_exception(error); };
  }
}

// Model threads yield the CPU to the event thread: on a machine with as many busy model threads as cores,
// equal priority would let a 100-ms fit hold the core the event loop needs to answer a heartbeat now.
// How much nicer, measured (tests/bench/proposal_throughput.sh, 20 studies on 8 x 16 slots, 2 cores, 3 runs
// each): +5 gave loop p99 46 / 19 / 27 ms, +10 12 / 11 / 11 ms at the same results/s, +19 19 / 86 / 12 ms
// and fewer results/s (the model threads then also lose the core to the workers' DDS threads).
void lower_this_threads_priority() {
  constexpr int kNicer = 10;
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  ::setpriority(PRIO_PROCESS, tid, ::getpriority(PRIO_PROCESS, tid) + kNicer);  // best effort
}

}  // namespace

ModelPool::ModelPool(int threads, std::function<void()> on_finished) : on_finished_(std::move(on_finished)) {
  for (int i = 0; i < threads; ++i) threads_.emplace_back([this] { thread_main(); });
}

ModelPool::~ModelPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  work_ready_.notify_all();
  for (auto& t : threads_) t.join();
}

void ModelPool::submit(std::uint64_t key, Work work) {
  if (threads_.empty()) {
    Completion done = run_catching(work);
    std::lock_guard<std::mutex> lock(mutex_);
    ++outstanding_;
    finished_.push_back(std::move(done));
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++outstanding_;
    ++submitted_not_finished_;
    auto& queue = queued_[key];
    queue.push_back(std::move(work));
    // A key becomes runnable when its first job is queued and none of its jobs runs; otherwise the
    // thread finishing the running job re-queues the key (one job per key at a time).
    if (queue.size() == 1 && !running_[key]) runnable_.push_back(key);
  }
  work_ready_.notify_one();
}

void ModelPool::thread_main() {
  lower_this_threads_priority();
  // Named so that `top -H`, perf and a debugger tell the model threads from the event and DDS threads.
  ::pthread_setname_np(::pthread_self(), "cpgmatch-model");
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    work_ready_.wait(lock, [&] { return stopping_ || !runnable_.empty(); });
    if (stopping_) return;
    const std::uint64_t key = runnable_.front();
    runnable_.pop_front();
    auto& queue = queued_[key];
    Work work = std::move(queue.front());
    queue.pop_front();
    running_[key] = true;
    lock.unlock();
    Completion done = run_catching(work);
    lock.lock();
    running_[key] = false;
    if (!queued_[key].empty()) {
      runnable_.push_back(key);
      work_ready_.notify_one();
    } else {
      queued_.erase(key);
      running_.erase(key);
    }
    finished_.push_back(std::move(done));
    if (--submitted_not_finished_ == 0) all_finished_.notify_all();
    if (on_finished_) {
      lock.unlock();
      on_finished_();
      lock.lock();
    }
  }
}

int ModelPool::run_finished() {
  int ran = 0;
  for (;;) {
    Completion done;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (finished_.empty()) return ran;
      done = std::move(finished_.front());
      finished_.pop_front();
      --outstanding_;
    }
    ++ran;
    done();  // may throw a job's exception; the remaining completions wait for the next call
  }
}

int ModelPool::outstanding() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return outstanding_;
}

void ModelPool::wait_until_finished() const {
  std::unique_lock<std::mutex> lock(mutex_);
  all_finished_.wait(lock, [&] { return submitted_not_finished_ == 0; });
}

}  // namespace cpgmatch::service

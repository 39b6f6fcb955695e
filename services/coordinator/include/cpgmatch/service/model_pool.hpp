// Runs the optimizer service's model work (GP fits, acquisition optimisation) on a bounded pool of
// threads, so the event thread that moves samples, store writes and timers never waits for a model.
//
//   ModelPool pool(2, [&] { wake_event_loop(); });
//   pool.submit(study_id, [opt] { auto points = opt->ask(4); return [points] { /* event thread */ }; });
//   ...
//   pool.run_finished();   // on the event thread: every finished job's completion, in finishing order
//
// Jobs with the same key run one at a time, in submission order (a study's tells and asks never run
// concurrently, and a tell submitted before an ask is applied before it); jobs with different keys run
// in parallel on up to `threads` threads. A job's work runs on a pool thread and returns a completion,
// which runs on the thread that calls run_finished(): that is where results touch shared state.
//
// threads = 0 runs each job inline inside submit() (its completion still waits for run_finished()):
// the same semantics without threads, for tests and for single-threaded tools.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

namespace cpgmatch::service {

class ModelPool {
 public:
  using Completion = std::function<void()>;
  using Work = std::function<Completion()>;

  // `on_finished` is called (from a pool thread) after each job finishes; it must only signal, e.g. wake
  // the event loop. Pool threads run at a lower scheduling priority than the caller (see model_pool.cpp).
  explicit ModelPool(int threads, std::function<void()> on_finished = {});
  ~ModelPool();  // finishes the jobs already running, drops the queued ones, joins the threads
  ModelPool(const ModelPool&) = delete;
  ModelPool& operator=(const ModelPool&) = delete;

  void submit(std::uint64_t key, Work work);
  // Runs the completions of the jobs finished so far; returns how many ran.
  int run_finished();
  // Jobs submitted and not yet completed (their completion has not run).
  int outstanding() const;
  // Blocks until every submitted job has finished (not completed: call run_finished() after). For tests.
  void wait_until_finished() const;
  int threads() const { return static_cast<int>(threads_.size()); }

 private:
  void thread_main();

  mutable std::mutex mutex_;
  mutable std::condition_variable work_ready_, all_finished_;
  std::map<std::uint64_t, std::deque<Work>> queued_;  // by key, in submission order
  std::deque<std::uint64_t> runnable_;                // keys with queued work and no job running
  std::map<std::uint64_t, bool> running_;             // keys with a job running now
  std::deque<Completion> finished_;
  int submitted_not_finished_ = 0;
  int outstanding_ = 0;
  bool stopping_ = false;
  std::function<void()> on_finished_;
  std::vector<std::thread> threads_;
};

}  // namespace cpgmatch::service

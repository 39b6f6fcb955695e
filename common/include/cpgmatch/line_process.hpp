// A child process kept between requests and spoken to in lines: one request line on its stdin, one answer
// line on its stdout (a worker slot's rollout process, `cpgmatch-sim-worker --serve-rollouts`).
//
// The child is exec'd directly (no shell), in a process group of its own, with PR_SET_PDEATHSIG = SIGKILL:
// it dies with the thread that started it, even when the worker is SIGKILLed, so use one LineProcess from
// one thread. Whatever goes wrong in an exchange (no answer before the deadline, the child ends, a write
// fails) ends the child: it is killed, reaped, and the next exchange starts a fresh one. Nothing here throws
// for a misbehaving child; the failure says what happened in run_command_objective's words.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace cpgmatch {

class LineProcess {
 public:
  using Clock = std::chrono::steady_clock;

  // argv[0] is the executable's path (not looked up in PATH).
  explicit LineProcess(std::vector<std::string> argv);
  ~LineProcess();  // stop()
  LineProcess(const LineProcess&) = delete;
  LineProcess& operator=(const LineProcess&) = delete;

  struct Reply {
    bool ok = false;
    std::string line;     // the answer, without its newline
    std::string failure;  // why there is none (the child has been killed and reaped)
  };
  // Starts a child when none is running, or when the one running is unfit (it ended, or it printed
  // something nobody asked for). False, with the reason, when no child could be started.
  bool ensure_running(std::string& failure);

  // Sends `request` (one line, no newline in it) and waits for one line back until `deadline`, after
  // ensure_running(). `timeout_s` only words the failure ("timed out after 2.0 s and was killed").
  Reply exchange(const std::string& request, Clock::time_point deadline, double timeout_s);

  // Ends the child now (SIGKILL to its group) and reaps it: one whose answers cannot be trusted.
  void kill_and_reap();

  // Waits until `deadline` for a child that said it is ending to exit, then kills it; reaps it either way.
  void reap_ending_child(Clock::time_point deadline);

  // Closes the child's stdin (it should exit at end of input) and waits up to `grace` before killing it.
  void stop(std::chrono::milliseconds grace = std::chrono::milliseconds(2000));

  pid_t pid() const { return pid_; }  // 0 when no child runs
  // Counts the children started so far: what a caller remembers about "the" child (what it was sent)
  // belongs to one generation.
  std::uint64_t generation() const { return generation_; }

 private:
  bool start(std::string& failure);
  bool fit_for_a_request();
  bool write_all(const std::string& text, Clock::time_point deadline, double timeout_s, std::string& failure);
  // How the child ended (it closed its stdout), waiting for it until `deadline`: "exited with status 3".
  std::string reap_after_end_of_output(Clock::time_point deadline, double timeout_s);
  void close_pipes();

  std::vector<std::string> argv_;
  pid_t pid_ = 0;
  int to_child_ = -1;
  int from_child_ = -1;
  std::string pending_;  // read from the child, not yet a whole line
  std::uint64_t generation_ = 0;
};

}  // namespace cpgmatch

#include "cpgmatch/line_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <thread>

#include <fmt/format.h>

namespace cpgmatch {
namespace {

int poll_ms_until(LineProcess::Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - LineProcess::Clock::now()).count();
  // At least 1 ms, so that a deadline a fraction of a millisecond away is waited for, not spun on.
  return static_cast<int>(std::clamp<long long>(left, 1, 50));
}

std::string how_it_ended(int status) {
  if (WIFSIGNALED(status)) return fmt::format("killed by signal {}", WTERMSIG(status));
  return fmt::format("exited with status {}", WEXITSTATUS(status));
}

void set_nonblocking(int fd) { fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK); }

}  // namespace

LineProcess::LineProcess(std::vector<std::string> argv) : argv_(std::move(argv)) {}

LineProcess::~LineProcess() { stop(); }

bool LineProcess::start(std::string& failure) {
  int in_pipe[2], out_pipe[2];
  // Close-on-exec, as in run_command_objective: a child forked by another slot's thread must not inherit
  // these ends, or this child would never see the end of its input.
  if (pipe2(in_pipe, O_CLOEXEC) != 0) {
    failure = fmt::format("cannot create pipes: {}", std::strerror(errno));
    return false;
  }
  if (pipe2(out_pipe, O_CLOEXEC) != 0) {
    failure = fmt::format("cannot create pipes: {}", std::strerror(errno));
    close(in_pipe[0]);
    close(in_pipe[1]);
    return false;
  }
  // Everything the child needs is made before fork: between fork and exec only async-signal-safe calls.
  std::vector<char*> args;
  for (std::string& a : argv_) args.push_back(a.data());
  args.push_back(nullptr);
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) {
    failure = fmt::format("cannot fork: {}", std::strerror(errno));
    for (int fd : {in_pipe[0], in_pipe[1], out_pipe[0], out_pipe[1]}) close(fd);
    return false;
  }
  if (pid == 0) {
    setpgid(0, 0);  // its own group: a kill reaches whatever it started too
    prctl(PR_SET_PDEATHSIG, SIGKILL);  // never an orphan, even when the worker is SIGKILLed
    if (getppid() != parent) _exit(1);  // the worker died before the line above
    dup2(in_pipe[0], STDIN_FILENO);
    dup2(out_pipe[1], STDOUT_FILENO);
    for (int fd : {in_pipe[0], in_pipe[1], out_pipe[0], out_pipe[1]}) close(fd);
    execv(args[0], args.data());
    _exit(127);
  }
  setpgid(pid, pid);
  close(in_pipe[0]);
  close(out_pipe[1]);
  // A child that died makes a write fail with EPIPE, which must be a failed exchange, not the end of the worker.
  signal(SIGPIPE, SIG_IGN);
  to_child_ = in_pipe[1];
  from_child_ = out_pipe[0];
  set_nonblocking(to_child_);  // a child that stops reading must not block us past the deadline
  set_nonblocking(from_child_);
  pid_ = pid;
  pending_.clear();
  ++generation_;
  return true;
}

bool LineProcess::fit_for_a_request() {
  if (pid_ == 0) return false;
  int status = 0;
  if (waitpid(pid_, &status, WNOHANG) == pid_) {  // it ended between requests (killed from outside)
    pid_ = 0;
    close_pipes();
    return false;
  }
  // Anything on its stdout before it was asked is output nobody can pair with a request: the stream is
  // out of step, so this child cannot be trusted with the next answer.
  char c;
  const ssize_t n = read(from_child_, &c, 1);
  if (!pending_.empty() || n >= 0) {  // n > 0: stray output; n == 0: it closed its stdout
    kill_and_reap();
    return false;
  }
  return true;  // n < 0 with EAGAIN: nothing to read, as it should be
}

bool LineProcess::ensure_running(std::string& failure) { return fit_for_a_request() || start(failure); }

bool LineProcess::write_all(const std::string& text, Clock::time_point deadline, double timeout_s, std::string& failure) {
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = write(to_child_, text.data() + written, text.size() - written);
    if (n > 0) {
      written += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno == EAGAIN) {
      if (Clock::now() >= deadline) return false;  // the caller words the timeout
      pollfd pfd{to_child_, POLLOUT, 0};
      poll(&pfd, 1, poll_ms_until(deadline));
      continue;
    }
    // EPIPE: the child is gone; say how it ended.
    failure = reap_after_end_of_output(deadline, timeout_s);
    return false;
  }
  return true;
}

LineProcess::Reply LineProcess::exchange(const std::string& request, Clock::time_point deadline, double timeout_s) {
  Reply reply;
  if (!ensure_running(reply.failure)) return reply;
  const std::string timed_out = fmt::format("timed out after {:.1f} s and was killed", timeout_s);
  if (!write_all(request + "\n", deadline, timeout_s, reply.failure)) {
    if (reply.failure.empty()) {
      kill_and_reap();
      reply.failure = timed_out;
    }
    return reply;
  }
  char buf[65536];
  while (true) {
    const std::size_t newline = pending_.find('\n');
    if (newline != std::string::npos) {
      reply.ok = true;
      reply.line = pending_.substr(0, newline);
      pending_.erase(0, newline + 1);  // anything left is stray output: the next exchange restarts the child
      return reply;
    }
    if (Clock::now() >= deadline) {
      kill_and_reap();
      reply.failure = timed_out;
      return reply;
    }
    pollfd pfd{from_child_, POLLIN, 0};
    if (poll(&pfd, 1, poll_ms_until(deadline)) <= 0) continue;
    const ssize_t n = read(from_child_, buf, sizeof(buf));
    if (n > 0) {
      pending_.append(buf, static_cast<std::size_t>(n));
    } else if (n == 0) {
      reply.failure = reap_after_end_of_output(deadline, timeout_s);
      return reply;
    } else if (errno != EAGAIN && errno != EINTR) {
      reply.failure = fmt::format("cannot read its output: {}", std::strerror(errno));
      kill_and_reap();
      return reply;
    }
  }
}

std::string LineProcess::reap_after_end_of_output(Clock::time_point deadline, double timeout_s) {
  // It closed its stdout, so it is ending; one that closed it and runs on is killed at the deadline.
  while (true) {
    int status = 0;
    const pid_t done = waitpid(pid_, &status, WNOHANG);
    if (done == pid_ || (done < 0 && errno != EINTR)) {
      const std::string how = done == pid_ ? how_it_ended(status) : "ended (cannot tell how)";
      pid_ = 0;
      close_pipes();
      return how;
    }

    if (Clock::now() >= deadline) {
      kill_and_reap();
      return fmt::format("closed its output, then timed out after {:.1f} s and was killed", timeout_s);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void LineProcess::reap_ending_child(Clock::time_point deadline) {
  if (pid_ == 0) return;
  close(to_child_);
  to_child_ = -1;
  while (Clock::now() < deadline) {
    int status = 0;
    const pid_t done = waitpid(pid_, &status, WNOHANG);
    if (done == pid_ || (done < 0 && errno != EINTR)) {
      pid_ = 0;
      close_pipes();
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  kill_and_reap();
}

void LineProcess::stop(std::chrono::milliseconds grace) { reap_ending_child(Clock::now() + grace); }

void LineProcess::kill_and_reap() {
  if (pid_ != 0) {
    kill(-pid_, SIGKILL);
    kill(pid_, SIGKILL);  // in case it has not made its group yet
    int status = 0;
    while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
    pid_ = 0;
  }
  close_pipes();
}

void LineProcess::close_pipes() {
  if (to_child_ >= 0) close(to_child_);
  if (from_child_ >= 0) close(from_child_);
  to_child_ = from_child_ = -1;
  pending_.clear();
}

}  // namespace cpgmatch

#include "cpgmatch/command_objective.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <sys/prctl.h>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include <fmt/format.h>

namespace cpgmatch {

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string self_executable() {
  char buf[4096];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return "cpgmatch";
  buf[n] = '\0';
  return buf;
}

EvaluationOutcome run_command_objective(const std::string& command, const std::string& stdin_text, double timeout_s) {
  EvaluationOutcome out;
  const auto start = std::chrono::steady_clock::now();
  int in_pipe[2], out_pipe[2];
  // Close-on-exec: a worker runs several slots at once, and a child forked by another thread while these
  // pipes exist would otherwise inherit their ends and keep this command's stdin (and stdout) open: neither
  // command sees end-of-file and both hang until their timeouts (seen in CI). dup2 onto 0 and 1 in the
  // child clears the flag for the two ends this command needs.
  if (pipe2(in_pipe, O_CLOEXEC) != 0 || pipe2(out_pipe, O_CLOEXEC) != 0) {
    out.message = fmt::format("cannot create pipes: {}", std::strerror(errno));
    return out;
  }
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) {
    out.message = fmt::format("cannot fork: {}", std::strerror(errno));
    return out;
  }
  if (pid == 0) {
    // Child: stdin from the parent's JSON, stdout to the parent; stderr passes through for diagnostics.
    setpgid(0, 0);  // own process group, so a timeout kills the whole pipeline
    // A rollout is worthless once its worker is gone (even SIGKILLed): do not run on as an orphan.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(1);
    dup2(in_pipe[0], STDIN_FILENO);
    dup2(out_pipe[1], STDOUT_FILENO);
    close(in_pipe[0]);
    close(in_pipe[1]);
    close(out_pipe[0]);
    close(out_pipe[1]);
    execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  setpgid(pid, pid);
  close(in_pipe[0]);
  close(out_pipe[1]);
  // The point is small (well below the pipe buffer), so one write never blocks on a child that
  // does not read its stdin.
  signal(SIGPIPE, SIG_IGN);
  if (write(in_pipe[1], stdin_text.data(), stdin_text.size()) < 0) { /* child may ignore stdin */ }
  close(in_pipe[1]);

  std::string captured;
  bool timed_out = false;
  char buf[4096];
  while (true) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (elapsed > timeout_s) {
      timed_out = true;
      kill(-pid, SIGKILL);
      break;
    }
    pollfd pfd{out_pipe[0], POLLIN, 0};
    const int ready = poll(&pfd, 1, 50);
    if (ready > 0) {
      const ssize_t n = read(out_pipe[0], buf, sizeof(buf));
      if (n <= 0) break;  // EOF: the command closed stdout
      captured.append(buf, static_cast<std::size_t>(n));
    }
  }
  close(out_pipe[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  out.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::istringstream lines(captured);
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty()) out.stdout_lines.push_back(line);
  }
  if (timed_out) {
    out.message = fmt::format("timed out after {:.1f} s and was killed", timeout_s);
    return out;
  }
  if (WIFSIGNALED(status)) {
    out.message = fmt::format("killed by signal {}", WTERMSIG(status));
    return out;
  }
  if (WEXITSTATUS(status) != 0) {
    out.message = fmt::format("exited with status {}", WEXITSTATUS(status));
    return out;
  }
  if (out.stdout_lines.empty()) {
    out.message = "printed nothing (expected the cost on the last line)";
    return out;
  }
  const std::string& last = out.stdout_lines.back();
  char* end = nullptr;
  const double value = std::strtod(last.c_str(), &end);
  while (end && *end && std::isspace(static_cast<unsigned char>(*end))) ++end;
  if (end == last.c_str() || (end && *end) || !std::isfinite(value)) {
    out.message = fmt::format("last line '{}' is not a finite number", last.substr(0, 80));
    return out;
  }
  out.ok = true;
  out.cost = value;
  return out;
}

}  // namespace cpgmatch

// Long-running child processes (the optimizer service and workers that `study run` starts).
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace cpgmatch::cli {

class ChildProcess {
 public:
  // Starts argv[0] with its stdout and stderr appended to `log_path`; throws std::runtime_error.
  ChildProcess(const std::vector<std::string>& argv, const std::string& log_path);
  ~ChildProcess();  // stop()
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool running();                   // false once it has exited (reaps it)
  void signal(int sig);             // sends `sig` if it is still running
  // SIGTERM, then SIGKILL after `grace_s`; returns its exit status (128+signal when killed).
  int stop(double grace_s = 5.0);
  pid_t pid() const { return pid_; }
  const std::string& name() const { return name_; }

 private:
  pid_t pid_ = -1;
  std::string name_;
  int status_ = -1;
};

}  // namespace cpgmatch::cli

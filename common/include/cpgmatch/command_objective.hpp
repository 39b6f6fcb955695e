// Runs an external objective: `sh -c CMD` with the point as JSON on stdin; the cost is the last line of
// its stdout. A non-zero exit, a timeout, a signal or a last line that is not a finite number is a
// failed evaluation with a message saying which; nothing here throws for a misbehaving command.
#pragma once

#include <string>
#include <vector>

namespace cpgmatch {

struct EvaluationOutcome {
  bool ok = false;
  double cost = 0.0;
  std::string message;                // why it failed, for the log
  std::vector<std::string> stdout_lines;
  double wall_time_s = 0.0;
};

EvaluationOutcome run_command_objective(const std::string& command, const std::string& stdin_text, double timeout_s);

// `s` as one single-quoted sh word.
std::string shell_quote(const std::string& s);

// Path of the running executable (to call our own subcommands as child processes).
std::string self_executable();

}  // namespace cpgmatch

// Commands to the optimizer service and its replies. A client re-sends a command whose reply it did not get;
// (client_id, correlation_id) ties the reply to the command and makes a re-sent command answered, not re-run.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace cpgmatch::domain {

// kExtend: a stopped or finished study continues with `added_trials` more (docs/steering.md).
// kEnqueue: `enqueue` gaits run as the study's next trials (Optuna's enqueue_trial).
enum class CommandKind { kSubmit, kPause, kResume, kStop, kExtend, kEnqueue };

// A known gait to run as a trial of the study: its parameter values (SI units) as a parameter file gives
// them, and that file's name for messages and the trial's record.
struct EnqueuedGait {
  std::string source;
  std::map<std::string, double> parameters;
};

struct StudyCommand {
  std::uint64_t correlation_id = 0;
  std::string client_id;
  CommandKind kind = CommandKind::kSubmit;
  int study_id = 0;         // pause / resume / stop
  std::string study_yaml;   // submit: the study file's text
  std::string source_name;  // submit: the file's name, for error messages
  int added_trials = 0;     // extend: trials added to the budget
  // submit: the gaits of the study file's `enqueue:` files, in its order; enqueue: the gaits to queue.
  std::vector<EnqueuedGait> enqueue;
};

struct CommandReply {
  std::uint64_t correlation_id = 0;
  std::string client_id;
  bool ok = false;
  int study_id = 0;
  std::string message;
};

// An operator stops robot agents (cpgmatch estop): the agent latches a stop until a release arrives.
struct EmergencyStop {
  std::uint64_t stop_id = 0;  // random per command: ties the agent's log lines to the command
  std::string target;         // a worker id, or "*" for every agent on the domain
  bool release = false;       // false: stop and latch; true: release the latch
  std::string reason;         // why, in the operator's words
  std::string sender;         // host:pid of the command, for the agent's log
};

}  // namespace cpgmatch::domain

#include "trace_intake.hpp"

#include <chrono>

#include <fmt/format.h>

#include "cpgmatch/domain/worker_identity.hpp"

namespace cpgmatch::service {
namespace {

double unix_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace

TraceIntake::TraceIntake(study::StudyStore& store, bool require_authenticated, Log info, Log warn,
                         domain::TraceAssemblerLimits limits)
    : store_(store), require_authenticated_(require_authenticated), info_(std::move(info)), warn_(std::move(warn)),
      assembler_(limits) {}

void TraceIntake::count_rejection(const std::string& line) {
  ++rejected_;
  // A flood of bad chunks must not flood the log: the first 20, then every 1000th, each with the count.
  if (rejected_ <= 20 || rejected_ % 1000 == 0) warn_(fmt::format("rejected {} (rejected so far: {})", line, rejected_));
}

void TraceIntake::reject(const std::string& why) { count_rejection("trace chunk: " + why); }

void TraceIntake::add(domain::RolloutTraceChunk chunk, double now_s, const std::optional<std::string>& sender) {
  if (require_authenticated_ && (!sender || !domain::worker_id_belongs_to(chunk.worker_id, *sender))) {
    return count_rejection(fmt::format("trace chunk of study {} trial {} from '{}': the sender's certificate ({}) does "
                                       "not own that worker id",
                                       chunk.id.study_id, chunk.id.trial_id, chunk.worker_id.substr(0, 64),
                                       sender ? "CN=" + *sender : "unknown"));
  }
  if (chunk.id.store_id != store_.store_id()) {
    // Another store's trial (an optimizer on the same domain, or one from before a fresh store): not ours.
    return count_rejection(fmt::format("trace chunk of study {} trial {}: store id {:016x} is not this store's",
                                       chunk.id.study_id, chunk.id.trial_id, chunk.id.store_id));
  }
  domain::TraceAssembler::Result r = assembler_.add(std::move(chunk), now_s);
  if (r.rejected) return count_rejection(*r.rejected);
  if (!r.complete) return;
  const domain::RolloutTrace& t = *r.complete;
  bool already_kept = false;
  if (auto why = store_.save_trace(t, unix_now_s(), &already_kept)) {
    return count_rejection(fmt::format("trace of study {} trial {} attempt {}: {}", t.id.study_id, t.id.trial_id,
                                       t.id.attempt, *why));
  }
  if (already_kept) return;  // the agent's history again, after a restart: kept already
  ++stored_;
  info_(fmt::format("study {} trial {}: stored the robot's trace ({} ticks at {} Hz{})", t.id.study_id, t.id.trial_id,
                    t.trace.ticks.size(), t.control_rate_hz,
                    t.ticks_dropped > 0 ? fmt::format(", {} later ticks not kept by the agent", t.ticks_dropped) : ""));
}

void TraceIntake::tick(double now_s) {
  for (const std::string& line : assembler_.expire(now_s)) count_rejection(line);
}

}  // namespace cpgmatch::service

// Puts rollout traces back together from their chunks (rollout_trace.hpp), under strict limits: whatever
// arrives (a chunk that contradicts its siblings, a trace larger than any rollout, chunks that never
// complete, a flood of half-sent traces), memory stays bounded and nothing throws. A refused chunk is
// counted with its reason; so is a partial trace given up, and the trace it belonged to is dropped whole.
//
// Not thread-safe: the optimizer's event thread owns it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "cpgmatch/domain/rollout_trace.hpp"

namespace cpgmatch::domain {

struct TraceAssemblerLimits {
  std::size_t max_ticks = kMaxTraceTicks;             // per trace
  std::size_t max_chunk_ticks = kTraceChunkTicks;     // per chunk
  std::size_t max_partial_traces = 4;                 // traces being assembled at once
  std::size_t max_buffered_ticks = 2 * kMaxTraceTicks;  // over all of them (about 26 MB)
  double max_age_s = 120.0;  // a partial trace not completed this long after its first chunk is given up
};

class TraceAssembler {
 public:
  explicit TraceAssembler(TraceAssemblerLimits limits = {});

  struct Result {
    std::optional<RolloutTrace> complete;  // the chunk completed this trace
    std::optional<std::string> rejected;   // the chunk was refused (why); nothing was kept of it
  };
  // Takes one chunk received at `now_s` (a monotonic clock).
  Result add(RolloutTraceChunk chunk, double now_s);
  // Gives up partial traces older than the limit; returns a line for each (for the log), counted as rejected.
  std::vector<std::string> expire(double now_s);

  std::uint64_t rejected_chunks() const { return rejected_chunks_; }
  std::uint64_t abandoned_traces() const { return abandoned_traces_; }
  std::size_t partial_traces() const { return partial_.size(); }
  std::size_t buffered_ticks() const { return buffered_ticks_; }

 private:
  using Key = std::tuple<std::uint64_t, int, int, int, std::string>;  // store, study, trial, attempt, worker
  struct Partial {
    RolloutTraceChunk header;  // the first chunk's header fields (its ticks moved out)
    std::vector<std::vector<MeasuredTick>> chunks;  // by index; empty until received
    std::vector<bool> received;
    std::vector<std::uint32_t> first_ticks;  // by index
    std::size_t chunks_received = 0;
    std::size_t ticks = 0;
    double started_s = 0.0;
  };
  std::optional<std::string> problem(const RolloutTraceChunk& chunk) const;
  void drop(std::map<Key, Partial>::iterator it);

  TraceAssemblerLimits limits_;
  std::map<Key, Partial> partial_;
  std::size_t buffered_ticks_ = 0;
  std::uint64_t rejected_chunks_ = 0;
  std::uint64_t abandoned_traces_ = 0;
};

}  // namespace cpgmatch::domain

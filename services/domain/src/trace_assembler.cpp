#include "cpgmatch/domain/trace_assembler.hpp"

#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "cpgmatch/domain/candidate.hpp"

namespace cpgmatch::domain {
namespace {

bool finite_tick(const MeasuredTick& t) {
  if (!std::isfinite(t.time_s) || !std::isfinite(t.pitch_rad) || !std::isfinite(t.vx_mps)) return false;
  for (const MeasuredLeg& l : t.legs) {
    if (!std::isfinite(l.hip_target_rad) || !std::isfinite(l.hip_rad) || !std::isfinite(l.knee_target_rad) ||
        !std::isfinite(l.knee_rad) || !std::isfinite(l.foot_force_n)) {
      return false;
    }
  }
  return true;
}

// The header every chunk of one trace repeats: chunks that disagree on it are not one trace.
bool same_header(const RolloutTraceChunk& a, const RolloutTraceChunk& b) {
  return a.chunk_count == b.chunk_count && a.total_ticks == b.total_ticks && a.control_rate_hz == b.control_rate_hz &&
         a.terrain == b.terrain && a.seed == b.seed && a.parameters == b.parameters && a.ticks_dropped == b.ticks_dropped;
}

std::string describe(const RolloutTraceChunk& c) {
  return fmt::format("study {} trial {} attempt {} from '{}', chunk {}/{}", c.id.study_id, c.id.trial_id, c.id.attempt,
                     c.worker_id.substr(0, 64), c.chunk_index, c.chunk_count);
}

}  // namespace

TraceAssembler::TraceAssembler(TraceAssemblerLimits limits) : limits_(limits) {}

// Everything a chunk can be checked for on its own.
std::optional<std::string> TraceAssembler::problem(const RolloutTraceChunk& c) const {
  if (c.worker_id.empty()) return "no worker id";
  if (c.id.study_id <= 0 || c.id.trial_id < 0 || c.id.attempt < 0) return "ids out of range";
  if (c.total_ticks < 2) return fmt::format("total_ticks {}: a trace has at least two ticks", c.total_ticks);
  if (c.total_ticks > limits_.max_ticks) {
    return fmt::format("total_ticks {} is more than a trace may hold ({})", c.total_ticks, limits_.max_ticks);
  }
  if (c.ticks.empty() || c.ticks.size() > limits_.max_chunk_ticks) {
    return fmt::format("{} ticks in one chunk (1 to {} allowed)", c.ticks.size(), limits_.max_chunk_ticks);
  }
  if (c.chunk_count == 0 || c.chunk_count > c.total_ticks ||
      static_cast<std::size_t>(c.chunk_count) * limits_.max_chunk_ticks < c.total_ticks) {
    return fmt::format("chunk_count {} cannot carry {} ticks", c.chunk_count, c.total_ticks);
  }
  if (c.chunk_index >= c.chunk_count) return fmt::format("chunk_index {} of {} chunks", c.chunk_index, c.chunk_count);
  if (static_cast<std::size_t>(c.first_tick) + c.ticks.size() > c.total_ticks) {
    return fmt::format("ticks {}..{} past the trace's {}", c.first_tick, c.first_tick + c.ticks.size(), c.total_ticks);
  }
  if (!(std::isfinite(c.control_rate_hz) && c.control_rate_hz > 0.0 && c.control_rate_hz <= 10000.0)) {
    return fmt::format("control_rate_hz {} is not in (0, 10000]", c.control_rate_hz);
  }
  if (auto why = check_parameters(c.parameters)) return "parameters: " + *why;
  // Ticks sit on the control grid from the rollout's start: t = index / rate (the replay relies on it).
  const double period = 1.0 / c.control_rate_hz;
  for (std::size_t i = 0; i < c.ticks.size(); ++i) {
    const MeasuredTick& t = c.ticks[i];
    if (!finite_tick(t)) return fmt::format("tick {}: a value is not finite", c.first_tick + i);
    const double expected = static_cast<double>(c.first_tick + i) * period;
    if (std::abs(t.time_s - expected) > 1e-6 + 1e-9 * expected) {
      return fmt::format("tick {}: time_s {} is not on the {} Hz grid ({})", c.first_tick + i, t.time_s,
                         c.control_rate_hz, expected);
    }
  }
  return std::nullopt;
}

void TraceAssembler::drop(std::map<Key, Partial>::iterator it) {
  buffered_ticks_ -= it->second.ticks;
  partial_.erase(it);
}

TraceAssembler::Result TraceAssembler::add(RolloutTraceChunk chunk, double now_s) {
  Result out;
  auto reject = [&](const std::string& why) {
    ++rejected_chunks_;
    out.rejected = fmt::format("trace chunk ({}): {}", describe(chunk), why);
    return out;
  };
  if (auto why = problem(chunk)) return reject(*why);
  const Key key{chunk.id.store_id, chunk.id.study_id, chunk.id.trial_id, chunk.id.attempt, chunk.worker_id};
  auto it = partial_.find(key);
  if (it == partial_.end()) {
    if (partial_.size() >= limits_.max_partial_traces) {
      return reject(fmt::format("{} traces are being assembled already (the limit)", partial_.size()));
    }
  } else if (!same_header(it->second.header, chunk)) {
    return reject("its header (length, rate, seed, terrain or parameters) differs from the trace's other chunks");
  } else if (it->second.received[chunk.chunk_index]) {
    return reject("this chunk was received already");
  }
  if (it != partial_.end() && it->second.ticks + chunk.ticks.size() > chunk.total_ticks) {
    return reject("more ticks than the trace's total");
  }
  if (buffered_ticks_ + chunk.ticks.size() > limits_.max_buffered_ticks) {
    return reject(fmt::format("{} ticks are buffered already (the limit is {})", buffered_ticks_, limits_.max_buffered_ticks));
  }
  if (it == partial_.end()) {
    Partial p;
    p.header = chunk;
    p.header.ticks.clear();
    p.chunks.resize(chunk.chunk_count);
    p.received.assign(chunk.chunk_count, false);
    p.first_ticks.assign(chunk.chunk_count, 0);
    p.started_s = now_s;
    it = partial_.emplace(key, std::move(p)).first;
  }
  Partial& p = it->second;
  const std::uint32_t index = chunk.chunk_index;
  const std::uint32_t first_tick = chunk.first_tick;
  p.ticks += chunk.ticks.size();
  buffered_ticks_ += chunk.ticks.size();
  p.received[index] = true;
  ++p.chunks_received;
  // Where the chunk starts is checked when the trace is whole: only then are its predecessors' sizes known.
  p.first_ticks[index] = first_tick;
  p.chunks[index] = std::move(chunk.ticks);
  if (p.chunks_received < p.chunks.size()) return out;

  RolloutTrace trace;
  const RolloutTraceChunk& h = p.header;
  trace.id = h.id;
  trace.worker_id = h.worker_id;
  trace.control_rate_hz = h.control_rate_hz;
  trace.terrain = h.terrain;
  trace.seed = h.seed;
  trace.parameters = h.parameters;
  trace.ticks_dropped = h.ticks_dropped;
  trace.trace.source = fmt::format("study {} trial {} attempt {} on {}", h.id.study_id, h.id.trial_id, h.id.attempt, h.worker_id);
  trace.trace.ticks.reserve(h.total_ticks);
  bool tiles = p.ticks == h.total_ticks;
  for (std::size_t i = 0; i < p.chunks.size(); ++i) {
    tiles = tiles && p.first_ticks[i] == trace.trace.ticks.size();
    trace.trace.ticks.insert(trace.trace.ticks.end(), p.chunks[i].begin(), p.chunks[i].end());
  }
  drop(it);
  if (!tiles) {
    ++abandoned_traces_;
    out.rejected = fmt::format("trace of study {} trial {} attempt {} from '{}': its chunks do not tile ticks 0..{}",
                               h.id.study_id, h.id.trial_id, h.id.attempt, h.worker_id.substr(0, 64), h.total_ticks);
    return out;
  }
  out.complete = std::move(trace);
  return out;
}

std::vector<std::string> TraceAssembler::expire(double now_s) {
  std::vector<std::string> lines;
  for (auto it = partial_.begin(); it != partial_.end();) {
    const auto next = std::next(it);
    const Partial& p = it->second;
    if (now_s - p.started_s > limits_.max_age_s) {
      ++abandoned_traces_;
      lines.push_back(fmt::format("gave up the trace of study {} trial {} attempt {} from '{}': {} of {} chunks in {:.0f} s",
                                  p.header.id.study_id, p.header.id.trial_id, p.header.id.attempt,
                                  p.header.worker_id.substr(0, 64), p.chunks_received, p.chunks.size(), now_s - p.started_s));
      drop(it);
    }
    it = next;
  }
  return lines;
}

}  // namespace cpgmatch::domain

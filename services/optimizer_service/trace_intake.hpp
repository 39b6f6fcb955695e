// The optimizer's side of cpgmatch/rollout_traces: each chunk a robot agent sends is checked, put together
// with its siblings (domain::TraceAssembler, under its limits) and, once whole, kept in the study's store
// (StudyStore::save_trace). A chunk or a trace that is malformed, too large, never completed, from a sender
// that does not own its worker id, or for a study or trial the store does not have is counted as rejected
// and logged; nothing about it reaches a study: the trial's report is counted on its own topic whatever
// becomes of its trace.
//
// Runs on the event thread, inside its store transaction (optimizer_service/main.cpp).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "cpgmatch/domain/trace_assembler.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::service {

class TraceIntake {
 public:
  using Log = std::function<void(const std::string&)>;
  // `require_authenticated`: with DDS-Security, a chunk counts only from the certificate owning its worker id.
  TraceIntake(study::StudyStore& store, bool require_authenticated, Log info, Log warn,
              domain::TraceAssemblerLimits limits = {});

  // One chunk, converted from the wire, received at `now_s` (monotonic) from `sender` (the authenticated
  // identity, when there is security). Throws only StoreWriteError (the store cannot be written).
  void add(domain::RolloutTraceChunk chunk, double now_s, const std::optional<std::string>& sender);
  // A chunk that could not even be converted (the transport's WireError).
  void reject(const std::string& why);
  // Gives up traces that stopped arriving (called every event-loop tick).
  void tick(double now_s);

  std::uint64_t stored() const { return stored_; }
  std::uint64_t rejected() const { return rejected_; }

 private:
  void count_rejection(const std::string& line);

  study::StudyStore& store_;
  bool require_authenticated_;
  Log info_, warn_;
  domain::TraceAssembler assembler_;
  std::uint64_t stored_ = 0;
  std::uint64_t rejected_ = 0;
};

}  // namespace cpgmatch::service

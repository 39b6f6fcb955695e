// What a robot (or a simulation standing in for one) did during a rollout, once per control tick: the joint
// commands, the measured joint angles, the contacts and the trunk. Calibration fits the model to these
// (services/calibration); the robot agent records them for every hardware rollout and sends them to the
// optimizer, which keeps them in the study's store. One type for all of them, so a trace read from a CSV, one
// recorded in memory and one from a store are the same thing to the fit.
//
// C++17 on purpose: idl/transport and the robot agent's DDS shell include this header.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "cpgmatch/domain/rollout_report.hpp"
#include "cpgmatch/legs.hpp"
#include "cpgmatch/rollout.hpp"

namespace cpgmatch::domain {

struct MeasuredLeg {
  double hip_target_rad = 0.0;   // commanded at this tick
  double hip_rad = 0.0;          // measured at this tick (before the command took effect)
  double knee_target_rad = 0.0;  // commanded knee flexion on top of the standing knee angle
  double knee_rad = 0.0;
  bool contact = false;          // the contact the controller saw at this tick
  double foot_force_n = 0.0;     // the foot sensor's reading (a FootTile's pressure as a force)
};

struct MeasuredTick {
  double time_s = 0.0;
  double pitch_rad = 0.0;  // + nose up
  double vx_mps = 0.0;     // forward speed over the ground
  PerLeg<MeasuredLeg> legs;  // one per leg of the robot
};

struct MeasuredTrace {
  std::string source;  // a file name or a description, for messages
  std::vector<MeasuredTick> ticks;  // one per control tick from the rollout's start (t = 0)
};

// One tick of a trace from the rollout's own sample (what run_rollout hands its TraceSink).
MeasuredTick to_measured_tick(const TraceSample& sample);

// A TraceSink that appends every tick of a rollout to `trace` (which must outlive the rollout).
TraceSink record_trace(MeasuredTrace& trace);

// A TraceSink for a real-time loop: `trace` gets room for `max_ticks` before the rollout starts, so that
// recording allocates nothing while the loop runs; ticks past that are counted in `dropped`, not kept (the
// beginning is what calibration fits; docs/robot_agent.md, "Rollout traces").
TraceSink record_trace_bounded(MeasuredTrace& trace, std::size_t max_ticks, std::uint64_t& dropped);

// A hardware rollout's trace with what it takes to replay it: which attempt it was, the CPG parameters and
// the conditions it ran with. The study's spec gives the rest (model, contact sensing, controller).
struct RolloutTrace {
  AttemptId id;
  std::string worker_id;
  double control_rate_hz = 0.0;  // the robot's own rate, which the ticks are spaced by
  std::string terrain;           // the candidate's (flat | step:H@D | rough:A | shift:H@T)
  std::uint64_t seed = 0;        // the candidate's rollout seed (contact-sensor noise)
  std::map<std::string, double> parameters;  // the complete CPG parameter set it ran, SI units
  std::uint64_t ticks_dropped = 0;  // control ticks of the rollout past what the agent keeps
  MeasuredTrace trace;
};

// The most ticks a trace holds, on the robot and in the store: 120 s at Morti's 500 Hz control rate (the
// paper's rollouts are 20 s; calibration fits the first few seconds). At most 13 MB in memory (216 bytes a
// tick), 11 MB on the wire and in the store (188 and 216 bytes a tick).
inline constexpr std::size_t kMaxTraceTicks = 60000;
// Ticks per chunk on the wire (cpgmatch/rollout_traces): 256 ticks of 27 numbers are about 50 kB, a few
// UDP fragments, and half a second of a 500 Hz rollout.
inline constexpr std::size_t kTraceChunkTicks = 256;
inline constexpr std::size_t kMaxTraceChunks = (kMaxTraceTicks + kTraceChunkTicks - 1) / kTraceChunkTicks;

// One piece of a RolloutTrace on the wire. Every chunk repeats the header (parameters, rate, seed), so the
// reassembly can check that the pieces belong together and needs no "first" chunk.
struct RolloutTraceChunk {
  AttemptId id;
  std::string worker_id;
  std::uint32_t chunk_index = 0;  // 0 .. chunk_count - 1
  std::uint32_t chunk_count = 0;
  std::uint32_t total_ticks = 0;  // of the whole trace
  std::uint32_t first_tick = 0;   // index of ticks[0] in the whole trace
  double control_rate_hz = 0.0;
  std::string terrain;
  std::uint64_t seed = 0;
  std::map<std::string, double> parameters;
  std::uint64_t ticks_dropped = 0;
  std::vector<MeasuredTick> ticks;
};

// Cuts a trace into chunks of at most `chunk_ticks` ticks (at least one chunk, even for an empty trace).
std::vector<RolloutTraceChunk> split_trace(const RolloutTrace& trace, std::size_t chunk_ticks = kTraceChunkTicks);

}  // namespace cpgmatch::domain

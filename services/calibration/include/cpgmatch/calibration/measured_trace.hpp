// What a robot (or a simulation standing in for one) did during a rollout, once per control tick: the
// joint commands, the measured joint angles, the contacts and the trunk. This is the input of calibration,
// kept apart from where it comes from: a trace CSV (`cpgmatch rollout --trace`, read_trace_csv), a rollout
// recorded in memory (record_trace), and later a study store's hardware reports.
#pragma once

#include <string>
#include <vector>

#include "cpgmatch/legs.hpp"
#include "cpgmatch/rollout.hpp"

namespace cpgmatch::calibration {

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
  PerLeg<MeasuredLeg> legs{};
};

struct MeasuredTrace {
  std::string source;  // a file name or a description, for messages
  std::vector<MeasuredTick> ticks;  // one per control tick from the rollout's start (t = 0)
};

// Reads the CSV `cpgmatch rollout --trace` writes (columns by name; extra columns are ignored). Throws
// InputError naming the file, the line and the column for a missing column, a cell that is not a number,
// or ticks that are not evenly spaced from t = 0.
MeasuredTrace read_trace_csv(const std::string& path);

// A TraceSink that appends every tick of a rollout to `trace` (which must outlive the rollout).
TraceSink record_trace(MeasuredTrace& trace);

// One tick of a trace from the rollout's own sample (shared by record_trace and the replay).
MeasuredTick to_measured_tick(const TraceSample& sample);

}  // namespace cpgmatch::calibration

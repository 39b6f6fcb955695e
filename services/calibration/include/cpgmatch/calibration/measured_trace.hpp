// What a robot (or a simulation standing in for one) did during a rollout, once per control tick: the
// joint commands, the measured joint angles, the contacts and the trunk. This is the input of calibration,
// kept apart from where it comes from: a trace CSV (`cpgmatch rollout --trace`, read_trace_csv), a rollout
// recorded in memory (record_trace), and a study store's hardware rollouts (stored_traces.hpp).
#pragma once

#include <string>
#include <vector>

#include "cpgmatch/domain/rollout_trace.hpp"

namespace cpgmatch::calibration {

// The trace types are the domain's (domain/rollout_trace.hpp): the robot agent records the same type, and
// a study store holds it.
using domain::MeasuredLeg;
using domain::MeasuredTick;
using domain::MeasuredTrace;
using domain::record_trace;
using domain::to_measured_tick;

// Reads the CSV `cpgmatch rollout --trace` writes (columns by name; extra columns are ignored). Throws
// InputError naming the file, the line and the column for a missing column, a cell that is not a number,
// or ticks that are not evenly spaced from t = 0.
MeasuredTrace read_trace_csv(const std::string& path);

}  // namespace cpgmatch::calibration

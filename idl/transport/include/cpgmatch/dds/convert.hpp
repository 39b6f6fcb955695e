// Conversions between the wire types and the science types, and validation of what arrives. Every
// check returns a reason instead of throwing, so a service can log and drop a bad sample and go on.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "cpgmatch/rollout.hpp"
#include "cpgmatch_msgs.h"

namespace cpgmatch::dds {

std::vector<msg::ParameterValue> to_wire(const std::map<std::string, double>& named);
std::map<std::string, double> from_wire(const std::vector<msg::ParameterValue>& values);

// Fills every measured field of `report` from a rollout result (ids and worker fields untouched).
void fill_report(msg::RolloutReport& report, const RolloutResult& result);

// The complete CPG parameter set a candidate carries, or a reason: unknown or repeated names, NaN or
// values outside a parameter's valid range.
std::optional<std::string> check_parameters(const std::vector<msg::ParameterValue>& values);

msg::RolloutOutcome to_wire(RolloutOutcome outcome);
std::string to_string(msg::RolloutOutcome outcome);  // completed|fell|refused|plant_fault|diverged|error
std::optional<msg::RolloutOutcome> outcome_from_string(const std::string& name);
// Refused, plant_fault, diverged: the rollout did not measure the point; its trial is issued again.
bool reissued_not_spent(msg::RolloutOutcome outcome);

// A reason to reject a report before it touches a study (NaN cost on an ok report, negative times...).
std::optional<std::string> check_report(const msg::RolloutReport& report);

// 64-bit FNV-1a of the worker id: the fixed-size key of the workers topic.
std::uint64_t worker_key(const std::string& worker_id);

// With DDS-Security a worker id belongs to the identity whose certificate has common name (CN) `common_name`:
// it is that CN, or the CN, '/' and a suffix (several worker processes of one identity: node12/1, node12/2).
// The optimizer counts a report, or takes an announcement, only from a sender whose certificate owns the
// worker id in it; an empty CN owns nothing.
bool worker_id_belongs_to(const std::string& worker_id, const std::string& common_name);

std::string to_string(msg::StudyStatus s);   // running|paused|done|failed|stopped
std::string to_string(msg::WorkerKind k);    // sim|hardware

}  // namespace cpgmatch::dds

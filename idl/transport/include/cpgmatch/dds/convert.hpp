// The one place where domain types (services/domain) meet the DDS wire types (msg::, generated from
// cpgmatch_msgs.idl). Everything above the transport speaks domain types; a DDS reader converts what arrives
// with from_wire() before anything else looks at it, and a writer sends to_wire() of what it was given.
//
// from_wire() refuses what the domain type cannot hold faithfully (an enum value out of range, a report whose
// ok/fell flags contradict its outcome, a parameter named twice) by throwing WireError with the field's name;
// range and plausibility checks of the values themselves are the domain's (domain::check_report,
// domain::check_parameters).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cpgmatch/domain/candidate.hpp"
#include "cpgmatch/domain/command.hpp"
#include "cpgmatch/domain/rollout_report.hpp"
#include "cpgmatch/domain/study_state.hpp"
#include "cpgmatch/domain/worker_announcement.hpp"
#include "cpgmatch/domain/worker_identity.hpp"
#include "cpgmatch_msgs.h"

namespace cpgmatch::dds {

// A sample the domain cannot take as it is; what() names the field and the value.
class WireError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The rules of worker identity are the domain's; the transport keys the workers topic with them.
using domain::worker_id_belongs_to;
using domain::worker_key;

// The attempt a candidate names, or nothing when its ids are past what the domain holds (no optimizer issued
// it): for answering or acknowledging a candidate that from_wire refuses, or without converting it whole.
std::optional<domain::AttemptId> attempt_of(const msg::Candidate& candidate);

std::vector<msg::ParameterValue> to_wire(const std::map<std::string, double>& named);
std::map<std::string, double> from_wire(const std::vector<msg::ParameterValue>& values);  // throws on a repeated name

msg::RolloutOutcome to_wire(domain::Outcome outcome);
msg::WorkerKind to_wire(domain::WorkerKind kind);
msg::StudyStatus to_wire(domain::StudyStatus status);
msg::CommandKind to_wire(domain::CommandKind kind);

msg::RolloutReport to_wire(const domain::RolloutReport& report);
domain::RolloutReport from_wire(const msg::RolloutReport& report);
msg::Candidate to_wire(const domain::Candidate& candidate);
domain::Candidate from_wire(const msg::Candidate& candidate);
msg::WorkerAnnouncement to_wire(const domain::WorkerAnnouncement& announcement);
domain::WorkerAnnouncement from_wire(const msg::WorkerAnnouncement& announcement);
msg::StudyCommand to_wire(const domain::StudyCommand& command);
domain::StudyCommand from_wire(const msg::StudyCommand& command);
msg::CommandReply to_wire(const domain::CommandReply& reply);
domain::CommandReply from_wire(const msg::CommandReply& reply);
msg::StudyState to_wire(const domain::StudyState& state);
domain::StudyState from_wire(const msg::StudyState& state);
msg::TrialRecord to_wire(const domain::TrialRecord& record);
domain::TrialRecord from_wire(const msg::TrialRecord& record);
msg::EmergencyStop to_wire(const domain::EmergencyStop& stop);
domain::EmergencyStop from_wire(const msg::EmergencyStop& stop);
msg::StudySpecSample to_wire(const domain::SpecPublication& spec);
domain::SpecPublication from_wire(const msg::StudySpecSample& spec);

}  // namespace cpgmatch::dds

// Every cpgmatch topic with its QoS, in one place (docs/dds.md is the reader's version of this file).
// Readers set reliability and durability explicitly: Fast DDS 2.9 readers default to BEST_EFFORT and
// VOLATILE, which would silently drop repairs and the state a late joiner needs.
#pragma once

#include <string>

#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include "cpgmatch_msgs.h"

namespace cpgmatch::dds {

enum class TopicId { kCandidates, kReports, kWorkers, kStudyState, kTrials, kCommands, kReplies, kEmergencyStop,
                     kStudySpecs, kRolloutTraces };

struct TopicInfo {
  const char* name;
  bool transient_local;     // late joiners get the writer's current samples
  int history_depth;        // KEEP_LAST depth per instance
  int max_instances;        // resource limit (Fast DDS's default of 10 would be a silent ceiling)
};

const TopicInfo& topic_info(TopicId id);

eprosima::fastdds::dds::DataWriterQos writer_qos(TopicId id);
eprosima::fastdds::dds::DataReaderQos reader_qos(TopicId id);

// The topic each message type travels on.
template <class T> struct TopicOf;
template <> struct TopicOf<msg::Candidate> { static constexpr TopicId id = TopicId::kCandidates; };
template <> struct TopicOf<msg::RolloutReport> { static constexpr TopicId id = TopicId::kReports; };
template <> struct TopicOf<msg::WorkerAnnouncement> { static constexpr TopicId id = TopicId::kWorkers; };
template <> struct TopicOf<msg::StudyState> { static constexpr TopicId id = TopicId::kStudyState; };
template <> struct TopicOf<msg::TrialRecord> { static constexpr TopicId id = TopicId::kTrials; };
template <> struct TopicOf<msg::StudyCommand> { static constexpr TopicId id = TopicId::kCommands; };
template <> struct TopicOf<msg::CommandReply> { static constexpr TopicId id = TopicId::kReplies; };
template <> struct TopicOf<msg::EmergencyStop> { static constexpr TopicId id = TopicId::kEmergencyStop; };
template <> struct TopicOf<msg::StudySpecSample> { static constexpr TopicId id = TopicId::kStudySpecs; };
template <> struct TopicOf<msg::RolloutTraceChunk> { static constexpr TopicId id = TopicId::kRolloutTraces; };

// Seconds a worker's announcement stays alive without a heartbeat (DDS liveliness lease).
inline constexpr double kWorkerLivelinessLease_s = 2.0;

}  // namespace cpgmatch::dds

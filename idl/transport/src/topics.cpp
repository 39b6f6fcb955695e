#include "cpgmatch/dds/topics.hpp"

#include <limits>
#include <stdexcept>

namespace cpgmatch::dds {

namespace dds = eprosima::fastdds::dds;

const TopicInfo& topic_info(TopicId id) {
  // Candidates and reports are transient-local so that a worker whose reader matches after the
  // candidate was written still gets it, and a restarted optimizer still gets reports written while it
  // was down. Both are keyed (study_id, trial_id): one instance per trial, last sample only.
  static const TopicInfo kCandidates{"cpgmatch/candidates", true, 1, 100000};
  static const TopicInfo kReports{"cpgmatch/reports", true, 1, 100000};
  static const TopicInfo kWorkers{"cpgmatch/workers", true, 1, 10000};
  static const TopicInfo kStudyState{"cpgmatch/study_state", true, 1, 10000};
  static const TopicInfo kTrials{"cpgmatch/trials", true, 1, 1000000};
  static const TopicInfo kCommands{"cpgmatch/commands", false, 256, 1};
  // Replies are transient-local: the client's reader can match the optimizer's writer a moment after
  // the client's command got through, and a volatile reply would then be lost. Commands stay volatile
  // so that a restarted optimizer never executes an old command again.
  static const TopicInfo kReplies{"cpgmatch/replies", true, 256, 1};
  // Emergency stops are volatile: a stop acts when it is heard and the agent latches it; a history that
  // outlived its sender would stop a robot restarted on purpose. The sender waits for its readers to
  // match and to acknowledge instead (cpgmatch estop).
  static const TopicInfo kEmergencyStop{"cpgmatch/estop", false, 16, 1};
  // Specs are transient-local, one sample per spec: a worker that joins mid-study gets every open study's
  // spec at once. The optimizer unregisters a spec when no open study uses it any more.
  static const TopicInfo kStudySpecs{"cpgmatch/study_specs", true, 1, 1000};
  // Trace chunks are volatile (a trace is worth having, not worth a late joiner's replay of megabytes) and
  // keyed by trial: one instance holds a whole trace's chunks (up to 235 at 256 ticks), so the depth must
  // keep every chunk until it is acknowledged. The agent unregisters a trace once it is acknowledged.
  static const TopicInfo kRolloutTraces{"cpgmatch/rollout_traces", false, 256, 8};
  switch (id) {
    case TopicId::kCandidates: return kCandidates;
    case TopicId::kReports: return kReports;
    case TopicId::kWorkers: return kWorkers;
    case TopicId::kStudyState: return kStudyState;
    case TopicId::kTrials: return kTrials;
    case TopicId::kCommands: return kCommands;
    case TopicId::kReplies: return kReplies;
    case TopicId::kEmergencyStop: return kEmergencyStop;
    case TopicId::kStudySpecs: return kStudySpecs;
    case TopicId::kRolloutTraces: return kRolloutTraces;
  }
  throw std::logic_error("unknown topic id");
}

namespace {

template <class Qos>
void apply_common(Qos& qos, const TopicInfo& info) {
  qos.reliability().kind = dds::RELIABLE_RELIABILITY_QOS;
  qos.durability().kind = info.transient_local ? dds::TRANSIENT_LOCAL_DURABILITY_QOS : dds::VOLATILE_DURABILITY_QOS;
  qos.history().kind = dds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = info.history_depth;
  qos.resource_limits().max_instances = info.max_instances;
  qos.resource_limits().max_samples_per_instance = info.history_depth;
  qos.resource_limits().max_samples = info.max_instances * info.history_depth;
  qos.resource_limits().allocated_samples = 64;
  // No data sharing (Fast DDS 2.9 turns it on by itself between processes on one host): its listener
  // thread was seen spinning at 50% of a core in a loaded run and then hanging the reader's destruction,
  // so `cpgmatch study submit` never exited; and its segments in /dev/shm (fast_datasharing_*) outlive a
  // SIGKILLed process. Loopback UDP is fast enough for these sample rates.
  qos.data_sharing().off();
}

}  // namespace

dds::DataWriterQos writer_qos(TopicId id) {
  const TopicInfo& info = topic_info(id);
  dds::DataWriterQos qos = dds::DATAWRITER_QOS_DEFAULT;
  apply_common(qos, info);
  // unregister_instance() also disposes (the default), so finished trials free the writer's memory.
  qos.writer_data_lifecycle().autodispose_unregistered_instances = true;
  if (id == TopicId::kWorkers) {
    // Alive while it announces: every announcement (each heartbeat_s, 0.5 s) asserts the writer's liveliness,
    // so no separate assertion travels. AUTOMATIC liveliness sent one more datagram (and its acknowledgement)
    // from every worker to the optimizer and to each discovery server, every quarter lease: 4 of a resting
    // worker's 10 datagrams a second (tests/bench/scale_out.sh, docs/dds.md). Readers that request AUTOMATIC
    // (cpgmatch's, other vendors' by default) still match: MANUAL_BY_TOPIC is the stronger offer.
    qos.liveliness().kind = dds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
    qos.liveliness().lease_duration = eprosima::fastrtps::Duration_t(kWorkerLivelinessLease_s);
  }
  if (id == TopicId::kCandidates) {
    // Each worker's reader filters on its worker id with cpgmatch's own filter class (worker_filter.hpp),
    // which this writer evaluates before sending: a candidate goes to its worker only. Fast DDS evaluates
    // at most 32 readers' filters by default and sends to the others unfiltered; no limit here. (Each
    // sample then carries every filtered reader's 16-byte signature in its inline QoS: 1.3 kB at 80
    // workers, 16 kB at 1,000; Fast DDS stops filtering past about 4,000, see docs/dds.md.)
    qos.writer_resource_limits().reader_filters_allocation =
        eprosima::fastrtps::ResourceLimitedContainerConfig(0, std::numeric_limits<std::size_t>::max(), 1);
  }
  if (id == TopicId::kRolloutTraces) {
    // A trace is a burst of 50 kB chunks; one the reader's socket dropped is repaired at the next
    // heartbeat, which by default comes 3 s later (measured: 3.0 s of a trace's 3.0 s delivery).
    qos.reliable_writer_qos().times.heartbeatPeriod = eprosima::fastrtps::Duration_t(0, 100000000);
  }
  // Writers never block the event loop for long when a reader is slow.
  qos.reliability().max_blocking_time = eprosima::fastrtps::Duration_t(0, 100000000);
  return qos;
}

dds::DataReaderQos reader_qos(TopicId id) {
  const TopicInfo& info = topic_info(id);
  dds::DataReaderQos qos = dds::DATAREADER_QOS_DEFAULT;
  apply_common(qos, info);
  if (id == TopicId::kWorkers) {
    qos.liveliness().kind = dds::AUTOMATIC_LIVELINESS_QOS;
    qos.liveliness().lease_duration = eprosima::fastrtps::Duration_t(kWorkerLivelinessLease_s);
  }
  return qos;
}

}  // namespace cpgmatch::dds

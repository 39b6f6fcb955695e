#include "cpgmatch/dds/ros2_view.hpp"

#include <algorithm>
#include <map>
#include <stdexcept>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fmt/format.h>

#include "cpgmatch/dds/ros2_convert.hpp"
#include "cpgmatch_ros2_msgsPubSubTypes.h"
#include "cpgmatch_ros2_msgsTypeObject.h"

namespace cpgmatch::dds {

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::types::ReturnCode_t;

namespace {

// QoS as rclcpp's defaults and `ros2 topic echo` expect them: reliable, KEEP_LAST; transient local where a
// late subscriber must get what was published before it came.
fdds::DataWriterQos view_qos(bool transient_local, int depth) {
  fdds::DataWriterQos qos = fdds::DATAWRITER_QOS_DEFAULT;
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  // A slow ROS 2 subscriber holds the optimizer's event loop 100 ms at most per write (as topics.cpp's writers).
  qos.reliability().max_blocking_time = eprosima::fastrtps::Duration_t(0, 100000000);
  qos.durability().kind = transient_local ? fdds::TRANSIENT_LOCAL_DURABILITY_QOS : fdds::VOLATILE_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = depth;
  qos.resource_limits().max_instances = 1;
  qos.resource_limits().max_samples_per_instance = depth;
  qos.resource_limits().max_samples = depth;
  qos.resource_limits().allocated_samples = std::min(depth, 16);
  qos.data_sharing().off();  // as every cpgmatch writer (topics.cpp)
  return qos;
}

fdds::Topic* make_topic(fdds::DomainParticipant* participant, fdds::TopicDataType* type, const char* name,
                        bool announce_types) {
  fdds::TypeSupport support(type);
  // Announcing TypeInformation is opt-in (announce_types): Cyclone DDS 0.10 (rmw_cyclonedds) refuses Fast
  // DDS 2.9's TYPE_INFORMATION parameter and drops the writer, so ROS 2 nodes on Cyclone would see nothing.
  // TypeObjects in discovery are never sent: Fast DDS 2.9 peers crashed building a dynamic type from one (seen
  // with a sequence of structs: every simulation worker on the domain, SIGSEGV in
  // TypeObjectFactory::build_dynamic_type); the recorder fetches them by TypeLookup instead.
  support->auto_fill_type_information(announce_types);
  support->auto_fill_type_object(false);
  if (support.register_type(participant) != ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error(fmt::format("DDS: cannot register type {}", support.get_type_name()));
  }
  fdds::Topic* topic = participant->create_topic(name, support.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  if (topic == nullptr) throw std::runtime_error(fmt::format("DDS: cannot create topic {}", name));
  return topic;
}

}  // namespace

struct Ros2View::Impl {
  fdds::Publisher* publisher = nullptr;
  fdds::Topic* state_topic = nullptr;
  fdds::Topic* trials_topic = nullptr;
  fdds::DataWriter* workers = nullptr;
  struct StudyWriters {
    fdds::DataWriter* state = nullptr;
    fdds::DataWriter* trials = nullptr;
  };
  std::map<int, StudyWriters> studies;
  std::map<std::uint64_t, domain::WorkerAnnouncement> last_heard;

  fdds::DataWriter* writer(fdds::Topic* topic, const fdds::DataWriterQos& qos) {
    fdds::DataWriter* w = publisher->create_datawriter(topic, qos);
    if (w == nullptr) throw std::runtime_error(fmt::format("DDS: cannot create a writer on {}", topic->get_name()));
    return w;
  }
  template <class T>
  static bool write(fdds::DataWriter* w, const T& sample) {
    return w->write(const_cast<T*>(&sample));
  }
  StudyWriters& writers_of(int study_id) {
    auto it = studies.find(study_id);
    if (it == studies.end()) {
      StudyWriters w;
      w.state = writer(state_topic, view_qos(true, 1));
      // Every trial of the study for a late subscriber; its budget (at most kMaxTrialsDepth) bounds how many
      // there are, and a KEEP_LAST history takes memory only for what was written.
      w.trials = writer(trials_topic, view_qos(true, kMaxTrialsDepth));
      it = studies.emplace(study_id, w).first;
    }
    return it->second;
  }
  void drop(int study_id) {
    const auto it = studies.find(study_id);
    if (it == studies.end()) return;
    if (it->second.state != nullptr) publisher->delete_datawriter(it->second.state);
    if (it->second.trials != nullptr) publisher->delete_datawriter(it->second.trials);
    studies.erase(it);
  }
};

Ros2View::Ros2View(Participant& participant, bool announce_types) : impl_(std::make_unique<Impl>()) {
  registercpgmatch_ros2_msgsTypes();  // the TypeObjects the TypeLookup service hands out
  impl_->publisher = participant.publisher();
  fdds::DomainParticipant* dp = const_cast<fdds::DomainParticipant*>(impl_->publisher->get_participant());
  impl_->state_topic =
      make_topic(dp, new cpgmatch_msgs::msg::dds_::StudyState_PubSubType(), kStateTopic, announce_types);
  impl_->trials_topic =
      make_topic(dp, new cpgmatch_msgs::msg::dds_::TrialRecord_PubSubType(), kTrialsTopic, announce_types);
  fdds::Topic* workers_topic =
      make_topic(dp, new cpgmatch_msgs::msg::dds_::Worker_PubSubType(), kWorkersTopic, announce_types);
  impl_->workers = impl_->writer(workers_topic, view_qos(false, kWorkersDepth));
}

Ros2View::~Ros2View() {
  while (!impl_->studies.empty()) impl_->drop(impl_->studies.begin()->first);
  if (impl_->workers != nullptr) impl_->publisher->delete_datawriter(impl_->workers);
}

bool Ros2View::publish_state(const domain::StudyState& state) {
  // A study first seen closed was finished before this service started: not part of the live view.
  if (impl_->studies.count(state.study_id) == 0 && !domain::is_open(state.status)) return true;
  try {
    return Impl::write(impl_->writers_of(state.study_id).state, to_ros(state));
  } catch (const std::runtime_error&) {
    return false;  // no writer for it (the caller says so): the view never stops the service
  }
}

bool Ros2View::publish_trial(const domain::TrialRecord& record) {
  try {
    // A resumed study's trials may come before its first state.
    return Impl::write(impl_->writers_of(record.study_id).trials, to_ros(record));
  } catch (const std::runtime_error&) {
    return false;
  }
}

void Ros2View::retire_study(int study_id) { impl_->drop(study_id); }

bool Ros2View::publish_worker(const domain::WorkerAnnouncement& announcement) {
  impl_->last_heard[announcement.worker_key] = announcement;
  return Impl::write(impl_->workers, to_ros(announcement, true));
}

bool Ros2View::worker_gone(std::uint64_t worker_key) {
  const auto it = impl_->last_heard.find(worker_key);
  if (it == impl_->last_heard.end()) return true;
  const domain::WorkerAnnouncement last = it->second;
  impl_->last_heard.erase(it);
  return Impl::write(impl_->workers, to_ros(last, false));
}

std::string Ros2View::worker_id_of(std::uint64_t worker_key) const {
  const auto it = impl_->last_heard.find(worker_key);
  return it == impl_->last_heard.end() ? std::string() : it->second.worker_id;
}

}  // namespace cpgmatch::dds

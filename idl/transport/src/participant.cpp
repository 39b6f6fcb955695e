#include "cpgmatch/dds/participant.hpp"

#include <algorithm>
#include <mutex>
#include <thread>

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <fmt/format.h>

#include "cpgmatch/dds/domain.hpp"
#include "cpgmatch/dds/profile.hpp"
#include "cpgmatch/dds/shm_cleanup.hpp"
#include "cpgmatch/dds/security.hpp"
#include "cpgmatch/dds/worker_filter.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch_msgsPubSubTypes.h"
#include "cpgmatch_msgsTypeObject.h"

namespace cpgmatch::dds {

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::types::ReturnCode_t;

namespace {

// With DDS-Security the usual reason an endpoint cannot be created is the identity's permissions.
std::string permission_hint() {
  const std::string enclave = selected_enclave();
  return enclave.empty() ? std::string()
                         : fmt::format(" (DDS-Security: enclave '{}' is not permitted to; see its permissions.xml)", enclave);
}

fdds::TypeSupport type_support(TopicId id) {
  switch (id) {
    case TopicId::kCandidates: return fdds::TypeSupport(new msg::CandidatePubSubType());
    case TopicId::kReports: return fdds::TypeSupport(new msg::RolloutReportPubSubType());
    case TopicId::kWorkers: return fdds::TypeSupport(new msg::WorkerAnnouncementPubSubType());
    case TopicId::kStudyState: return fdds::TypeSupport(new msg::StudyStatePubSubType());
    case TopicId::kTrials: return fdds::TypeSupport(new msg::TrialRecordPubSubType());
    case TopicId::kCommands: return fdds::TypeSupport(new msg::StudyCommandPubSubType());
    case TopicId::kReplies: return fdds::TypeSupport(new msg::CommandReplyPubSubType());
    case TopicId::kEmergencyStop: return fdds::TypeSupport(new msg::EmergencyStopPubSubType());
    case TopicId::kStudySpecs: return fdds::TypeSupport(new msg::StudySpecSamplePubSubType());
    case TopicId::kRolloutTraces: return fdds::TypeSupport(new msg::RolloutTraceChunkPubSubType());
  }
  throw std::logic_error("unknown topic id");
}

}  // namespace

Participant::Participant(const ParticipantConfig& config) : domain_(config.domain) {
  validate_domain(config.domain);
  // The DDS-SQL content filter looks types up in the TypeObject registry; generated code only fills it
  // when a message is first constructed, which may be after a filtered reader is created.
  registercpgmatch_msgsTypes();
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  // Start from the default profile so $FASTRTPS_DEFAULT_PROFILES_FILE (discovery server, security,
  // transports) applies to every cpgmatch process without code changes.
  // load_profiles() first: the factory reads the XML lazily, and the default QoS asked for before that
  // would silently ignore the profile (security, transports, discovery server).
  if (factory->load_profiles() != ReturnCode_t::RETCODE_OK) {
    throw InputError("FASTRTPS_DEFAULT_PROFILES_FILE: the Fast DDS XML profile could not be loaded");
  }
  fdds::DomainParticipantQos qos;
  factory->get_default_participant_qos(qos);
  apply_discovery_servers(qos);
  apply_security(qos);
  qos.name(config.name);
  if (config.serve_type_lookup) qos.wire_protocol().builtin.typelookup_config.use_server = true;
  if (config.localhost_only) {
    // UDP on 127.0.0.1 only, discovery by unicast to the well-known ports of the first 64 participant
    // ids on this host. No shared memory: after a SIGKILL its segments can be left half-owned, and a
    // participant restarted on the same ports then stops hearing new peers (seen in the restart test).
    qos.transport().use_builtin_transports = false;
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList.emplace_back("127.0.0.1");
    // RTPS port mapping: 7400 + 250 * domain + 10 + 2 * participant id must stay below 65536.
    const int free_ids = (65535 - 7400 - 250 * config.domain - 11) / 2;
    udp->maxInitialPeersRange = static_cast<std::uint32_t>(std::clamp(free_ids, 1, 64));
    qos.transport().user_transports.push_back(udp);
    eprosima::fastrtps::rtps::Locator_t peer;
    eprosima::fastrtps::rtps::IPLocator::setIPv4(peer, 127, 0, 0, 1);
    qos.wire_protocol().builtin.initialPeersList.clear();
    qos.wire_protocol().builtin.initialPeersList.push_back(peer);
  }
  peer_listener_.on_peer = config.on_peer_discovered;
  peer_listener_.track_identities = config.track_identities;
  peer_listener_.on_identity_refused = config.on_identity_refused;
  // StatusMask::none(): the listener takes no data or QoS callbacks from the entities; discovery
  // callbacks are delivered regardless of the mask.
  if (!config.localhost_only) {
    // This participant may use Fast DDS's shared memory: first remove what SIGKILLed processes left there
    // (once per process; a participant restarted beside a zombie port could otherwise stop hearing peers).
    static std::once_flag cleaned;
    std::call_once(cleaned, [] {
      const ShmCleanup c = remove_dead_shm_segments();
      if (c.segments_removed + c.ports_removed > 0) {
        fmt::print(stderr, "cpgmatch: removed {} segments and {} ports of dead Fast DDS processes from /dev/shm\n",
                   c.segments_removed, c.ports_removed);
      }
    });
  }
  participant_ = config.on_peer_discovered || config.track_identities
                     ? factory->create_participant(config.domain, qos, &peer_listener_, fdds::StatusMask::none())
                     : factory->create_participant(config.domain, qos);
  if (participant_ == nullptr) {
    throw std::runtime_error(fmt::format("DDS: cannot create a participant on domain {}", config.domain));
  }
  // Before any writer: a writer filters for a reader only when its own participant knows the reader's
  // filter class when they match (worker_filter.hpp).
  if (participant_->register_content_filter_factory(kWorkerIdFilterClass, &WorkerIdFilterFactory::instance()) !=
      ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("DDS: cannot register the worker-id content filter");
  }
  publisher_ = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  subscriber_ = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (publisher_ == nullptr || subscriber_ == nullptr) throw std::runtime_error("DDS: cannot create publisher/subscriber");
}

void Participant::PeerListener::on_participant_discovery(eprosima::fastdds::dds::DomainParticipant*,
                                                         eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) {
  using Info = eprosima::fastrtps::rtps::ParticipantDiscoveryInfo;
  const auto& prefix = info.info.m_guid.guidPrefix;
  if (track_identities) {
    if (info.status == Info::DISCOVERED_PARTICIPANT || info.status == Info::CHANGED_QOS_PARTICIPANT) {
      // With DDS-Security, Fast DDS only matches endpoints of participants it authenticated; the
      // announced subject is checked against the GUID it authenticated (authenticated_common_name).
      std::string subject, why;
      for (const auto& property : info.info.identity_token_.properties()) {
        if (property.name() == "dds.cert.sn") subject = property.value();
      }
      const std::optional<std::string> cn = authenticated_common_name(subject, prefix.value, why);
      std::lock_guard<std::mutex> lock(mutex);
      if (cn) {
        identities[prefix] = *cn;
      } else {
        identities.erase(prefix);
        // No IdentityToken at all: an unauthenticated participant, which Fast DDS itself never matches
        // (governance: allow_unauthenticated_participants false); nothing to say about it.
        if (on_identity_refused && !subject.empty()) {
          on_identity_refused(fmt::format("participant '{}': no authenticated identity: {}",
                                          info.info.m_participantName.to_string(), why));
        }
      }
    } else if (info.status == Info::REMOVED_PARTICIPANT || info.status == Info::DROPPED_PARTICIPANT) {
      std::lock_guard<std::mutex> lock(mutex);
      identities.erase(prefix);
    }
  }
  if (on_peer && info.status == Info::DISCOVERED_PARTICIPANT) {
    on_peer(info.info.m_participantName.to_string());
  }
}

std::optional<std::string> Participant::identity_of(const eprosima::fastrtps::rtps::GuidPrefix_t& prefix) const {
  std::lock_guard<std::mutex> lock(peer_listener_.mutex);
  const auto it = peer_listener_.identities.find(prefix);
  if (it == peer_listener_.identities.end()) return std::nullopt;
  return it->second;
}

Participant::~Participant() {
  if (participant_ == nullptr) return;
  participant_->delete_contained_entities();
  participant_->unregister_content_filter_factory(kWorkerIdFilterClass);
  fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
}

fdds::Topic* Participant::topic(TopicId id) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (auto it = topics_.find(id); it != topics_.end()) return it->second;
  fdds::TypeSupport type = type_support(id);
  // Do not announce XTypes TypeInformation/TypeObject in discovery: Cyclone DDS 0.10 rejects Fast DDS
  // 2.9's TYPE_INFORMATION parameter as invalid and drops the endpoint (tests/interop shows it).
  // Matching then goes by type name, which both vendors generate identically from the same IDL.
  // The content filter still finds the types in the local TypeObject registry.
  type->auto_fill_type_information(false);
  type->auto_fill_type_object(false);
  if (type.register_type(participant_) != ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error(fmt::format("DDS: cannot register type {}", type.get_type_name()));
  }
  fdds::Topic* t = participant_->create_topic(topic_info(id).name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  if (t == nullptr) throw std::runtime_error(fmt::format("DDS: cannot create topic {}", topic_info(id).name));
  topics_[id] = t;
  return t;
}

fdds::ContentFilteredTopic* Participant::filtered_topic(TopicId id, const std::string& name,
                                                        const std::string& expression,
                                                        const std::vector<std::string>& parameters,
                                                        const char* filter_class) {
  fdds::Topic* base = topic(id);
  std::lock_guard<std::mutex> lock(mutex_);
  fdds::ContentFilteredTopic* t =
      filter_class == nullptr ? participant_->create_contentfilteredtopic(name, base, expression, parameters)
                              : participant_->create_contentfilteredtopic(name, base, expression, parameters, filter_class);
  if (t == nullptr) {
    throw std::runtime_error(fmt::format("DDS: cannot create content filter '{}' on {}", expression, topic_info(id).name));
  }
  return t;
}

bool MatchCounter::wait_for(int n, std::chrono::milliseconds timeout) const {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (count() < n) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

namespace detail {

fdds::DataWriter* create_writer(Participant& p, TopicId id, fdds::DataWriterListener* listener) {
  fdds::DataWriter* w = p.publisher()->create_datawriter(p.topic(id), writer_qos(id), listener,
                                                         fdds::StatusMask::publication_matched());
  if (w == nullptr) {
    throw std::runtime_error(fmt::format("DDS: cannot create a writer on {}{}", topic_info(id).name, permission_hint()));
  }
  return w;
}

fdds::DataReader* create_reader(Participant& p, fdds::TopicDescription* topic, TopicId id,
                                fdds::DataReaderListener* listener) {
  fdds::DataReader* r = p.subscriber()->create_datareader(
      topic, reader_qos(id), listener, fdds::StatusMask::data_available() << fdds::StatusMask::subscription_matched());
  if (r == nullptr) {
    throw std::runtime_error(fmt::format("DDS: cannot create a reader on {}{}", topic_info(id).name, permission_hint()));
  }
  return r;
}

void delete_writer(Participant& p, fdds::DataWriter* w) {
  if (w != nullptr) p.publisher()->delete_datawriter(w);
}

void delete_reader(Participant& p, fdds::DataReader* r) {
  if (r != nullptr) p.subscriber()->delete_datareader(r);
}

}  // namespace detail
}  // namespace cpgmatch::dds

// A DDS participant with cpgmatch's topics, and typed writers and readers on them. This is the only
// place that creates Fast DDS entities; the rest of the service code works with the generated message
// structs and these two templates.
//
//   dds::Participant p(dds::ParticipantConfig{7, "optimizer", false});
//   dds::Writer<msg::Candidate> out(p);
//   dds::Reader<msg::RolloutReport> in(p, [&](const msg::RolloutReport& r) { queue.push(r); });
//
// Reader callbacks run on a Fast DDS thread: hand the sample to your own thread, do not block.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/ContentFilteredTopic.hpp>
#include <fastdds/dds/topic/Topic.hpp>

#include "cpgmatch/dds/topics.hpp"
#include "cpgmatch/dds/worker_filter.hpp"

namespace cpgmatch::dds {

struct ParticipantConfig {
  int domain = 0;
  std::string name = "cpgmatch";
  // UDP on 127.0.0.1 only, unicast discovery: a private study on one machine (`study run`, tests).
  // Otherwise Fast DDS's defaults apply, or the XML profile in $FASTRTPS_DEFAULT_PROFILES_FILE.
  bool localhost_only = false;
  // Called (on a DDS thread) with the name of every remote participant that joins the domain; how the
  // optimizer notices a second optimizer on its domain.
  std::function<void(const std::string& name)> on_peer_discovered;
  // Keep the authenticated identity (certificate CN) of every remote participant, so that samples can be
  // attributed to it (Participant::identity_of). Only meaningful with DDS-Security.
  bool track_identities = false;
  // Called (on a DDS thread) when a remote participant's announced identity is refused (see
  // authenticated_common_name), with its GUID prefix and the reason.
  std::function<void(const std::string& what)> on_identity_refused;
  // Answer XTypes TypeLookup requests, so tools that discover types (DDS Record & Replay) can get the types
  // of writers that announce TypeInformation (the ROS 2 view's, ros2_view.hpp).
  bool serve_type_lookup = false;

  // The common case: a participant on `domain` called `name`, without callbacks or identity tracking.
  static ParticipantConfig basic(int domain, std::string name, bool localhost_only) {
    ParticipantConfig c;
    c.domain = domain;
    c.name = std::move(name);
    c.localhost_only = localhost_only;
    return c;
  }
};

// Where a sample came from: the GUID prefix of the writing participant.
struct SampleOrigin {
  eprosima::fastrtps::rtps::GuidPrefix_t participant;
};

class Participant {
 public:
  explicit Participant(const ParticipantConfig& config);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  eprosima::fastdds::dds::Topic* topic(TopicId id);
  // A content filter on `id`, e.g. ("worker_id = %0", {"'w1'"}) in DDS-SQL (filter_class null), or a
  // custom filter class registered on every participant (worker_filter.hpp). One per (topic, name).
  eprosima::fastdds::dds::ContentFilteredTopic* filtered_topic(TopicId id, const std::string& name,
                                                               const std::string& expression,
                                                               const std::vector<std::string>& parameters,
                                                               const char* filter_class = nullptr);
  eprosima::fastdds::dds::Publisher* publisher() { return publisher_; }
  eprosima::fastdds::dds::Subscriber* subscriber() { return subscriber_; }
  int domain() const { return domain_; }
  // The CN of the certificate DDS-Security authenticated for the remote participant `prefix` (needs
  // track_identities); nothing when unknown: no security, not (or no longer) discovered, or a participant
  // whose IdentityToken announces a subject its GUID was not derived from.
  std::optional<std::string> identity_of(const eprosima::fastrtps::rtps::GuidPrefix_t& prefix) const;

 private:
  int domain_;
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  std::mutex mutex_;
  std::map<TopicId, eprosima::fastdds::dds::Topic*> topics_;
  struct PeerListener : eprosima::fastdds::dds::DomainParticipantListener {
    std::function<void(const std::string&)> on_peer;
    bool track_identities = false;
    std::function<void(const std::string&)> on_identity_refused;
    mutable std::mutex mutex;
    std::map<eprosima::fastrtps::rtps::GuidPrefix_t, std::string> identities;  // participant -> CN
    void on_participant_discovery(eprosima::fastdds::dds::DomainParticipant* participant,
                                  eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override;
  };
  PeerListener peer_listener_;
};

// Counts matched remote endpoints, so a client can wait until the service hears it.
class MatchCounter {
 public:
  void add(int change) { count_ += change; }
  int count() const { return count_.load(); }
  // True once at least `n` are matched; false after `timeout`.
  bool wait_for(int n, std::chrono::milliseconds timeout) const;

 private:
  std::atomic<int> count_{0};
};

namespace detail {
// Creates/deletes DataWriters and DataReaders; kept out of the templates to keep them small.
eprosima::fastdds::dds::DataWriter* create_writer(Participant& p, TopicId id,
                                                  eprosima::fastdds::dds::DataWriterListener* listener);
eprosima::fastdds::dds::DataReader* create_reader(Participant& p, eprosima::fastdds::dds::TopicDescription* topic,
                                                  TopicId id, eprosima::fastdds::dds::DataReaderListener* listener);
void delete_writer(Participant& p, eprosima::fastdds::dds::DataWriter* w);
void delete_reader(Participant& p, eprosima::fastdds::dds::DataReader* r);
}  // namespace detail

template <class T>
class Writer {
 public:
  explicit Writer(Participant& p) : participant_(p) {
    writer_ = detail::create_writer(p, TopicOf<T>::id, &listener_);
  }
  ~Writer() { detail::delete_writer(participant_, writer_); }
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  bool write(const T& sample) { return writer_->write(const_cast<T*>(&sample)); }
  // Removes the instance with `sample`'s key from the writer (and disposes it for readers).
  bool unregister(const T& sample) {
    // A candidate's dispose goes to the worker it was addressed to only (worker_filter.hpp).
    std::string addressee;
    std::optional<AddressedTo> to;  // destroyed before `addressee`, which it points to
    if constexpr (std::is_same_v<T, msg::Candidate>) {
      addressee = sample.worker_id().to_string();
      to.emplace(addressee);
    }
    return writer_->unregister_instance(const_cast<T*>(&sample), eprosima::fastrtps::rtps::InstanceHandle_t()) ==
           ReturnCode_OK();
  }
  const MatchCounter& matched() const { return listener_.matched; }
  // True once every matched reliable reader has acknowledged everything written; false after `timeout`.
  bool wait_for_acknowledgments(std::chrono::milliseconds timeout) {
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(timeout).count();
    return writer_->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(static_cast<int32_t>(ns / 1000000000),
                                                                            static_cast<uint32_t>(ns % 1000000000))) ==
           ReturnCode_OK();
  }

 private:
  static eprosima::fastrtps::types::ReturnCode_t ReturnCode_OK() {
    return eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
  }
  struct Listener : eprosima::fastdds::dds::DataWriterListener {
    void on_publication_matched(eprosima::fastdds::dds::DataWriter*,
                                const eprosima::fastdds::dds::PublicationMatchedStatus& s) override {
      matched.add(s.current_count_change);
    }
    MatchCounter matched;
  };
  Participant& participant_;
  Listener listener_;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
};

// What a reader reports besides data: an instance whose writer vanished or disposed it.
struct InstanceGone {
  bool disposed = false;  // false: no writer is alive any more (crash, lost liveliness)
  // A dispose: the participant whose writer disposed it (who may speak for the instance is the caller's
  // question, e.g. with DDS-Security). Unknown (zero) when no writer is left.
  SampleOrigin origin{};
};

template <class T>
class Reader {
 public:
  using OnSample = std::function<void(const T&)>;
  // `on_gone` gets the key fields of an instance that was disposed or lost all its writers.
  using OnGone = std::function<void(const T& key, InstanceGone)>;
  // Also told which participant wrote the sample (to look up its authenticated identity).
  using OnSampleFrom = std::function<void(const T&, const SampleOrigin&)>;
  struct WithOrigin {};

  Reader(Participant& p, OnSample on_sample, OnGone on_gone = {})
      : participant_(p), listener_(std::move(on_sample), std::move(on_gone)) {
    reader_ = detail::create_reader(p, p.topic(TopicOf<T>::id), TopicOf<T>::id, &listener_);
  }
  Reader(Participant& p, WithOrigin, OnSampleFrom on_sample, OnGone on_gone = {})
      : participant_(p), listener_(OnSample{}, std::move(on_gone)) {
    listener_.on_sample_from = std::move(on_sample);
    reader_ = detail::create_reader(p, p.topic(TopicOf<T>::id), TopicOf<T>::id, &listener_);
  }
  // Reads only samples matching a DDS-SQL `expression` with `parameters` (a content-filtered topic).
  Reader(Participant& p, const std::string& filter_name, const std::string& expression,
         const std::vector<std::string>& parameters, OnSample on_sample, OnGone on_gone = {})
      : participant_(p), listener_(std::move(on_sample), std::move(on_gone)) {
    reader_ = detail::create_reader(p, p.filtered_topic(TopicOf<T>::id, filter_name, expression, parameters),
                                    TopicOf<T>::id, &listener_);
  }
  // Reads only the candidates addressed to `worker_id` (and their disposes), filtered by the writer where
  // it knows the filter class (every cpgmatch participant does, worker_filter.hpp).
  struct AddressedToWorker {
    std::string worker_id;
  };
  Reader(Participant& p, const AddressedToWorker& to, OnSample on_sample, OnGone on_gone = {})
      : participant_(p), listener_(std::move(on_sample), std::move(on_gone)) {
    static_assert(std::is_same_v<T, msg::Candidate>, "the worker-id filter reads candidates only");
    reader_ = detail::create_reader(
        p, p.filtered_topic(TopicOf<T>::id, "cpgmatch/candidates/" + to.worker_id, kWorkerIdFilterExpression,
                            {to.worker_id}, kWorkerIdFilterClass),
        TopicOf<T>::id, &listener_);
  }
  ~Reader() { detail::delete_reader(participant_, reader_); }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  const MatchCounter& matched() const { return listener_.matched; }

 private:
  struct Listener : eprosima::fastdds::dds::DataReaderListener {
    Listener(OnSample s, OnGone g) : on_sample(std::move(s)), on_gone(std::move(g)) {}
    void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
      namespace dds = eprosima::fastdds::dds;
      T sample;
      dds::SampleInfo info;
      while (reader->take_next_sample(&sample, &info) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
        if (info.valid_data) {
          // Remember each instance's key: a dispose or a lost writer arrives with the handle only.
          if (on_gone) last_by_instance[info.instance_handle] = sample;
          if (on_sample) on_sample(sample);
          if (on_sample_from) on_sample_from(sample, SampleOrigin{info.sample_identity.writer_guid().guidPrefix});
        } else if (on_gone) {
          const auto it = last_by_instance.find(info.instance_handle);
          if (it == last_by_instance.end()) continue;
          const T key = it->second;
          last_by_instance.erase(it);
          on_gone(key, InstanceGone{info.instance_state == dds::NOT_ALIVE_DISPOSED_INSTANCE_STATE,
                                    SampleOrigin{info.sample_identity.writer_guid().guidPrefix}});
        }
      }
    }
    void on_subscription_matched(eprosima::fastdds::dds::DataReader*,
                                 const eprosima::fastdds::dds::SubscriptionMatchedStatus& s) override {
      matched.add(s.current_count_change);
    }
    OnSample on_sample;
    OnSampleFrom on_sample_from;
    OnGone on_gone;
    MatchCounter matched;
    std::map<eprosima::fastrtps::rtps::InstanceHandle_t, T> last_by_instance;
  };
  Participant& participant_;
  Listener listener_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
};

}  // namespace cpgmatch::dds

// The ROS 2 view (ros2_view.hpp): its messages, what a late ROS 2 subscriber gets on a real DDS domain,
// and the ROS 2 environment variables as defaults of --domain, --keystore and --enclave.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>
#include <thread>

#include <sys/wait.h>
#include <unistd.h>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastrtps/types/DynamicType.h>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "cpgmatch/dds/domain.hpp"
#include "cpgmatch/dds/participant.hpp"
#include "cpgmatch/dds/ros2_convert.hpp"
#include "cpgmatch/dds/ros2_view.hpp"
#include "cpgmatch/dds/security.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/runtime/shared_flags.hpp"
#include "cpgmatch_ros2_msgsPubSubTypes.h"

namespace cpgmatch {
namespace {

using namespace std::chrono_literals;
namespace fdds = eprosima::fastdds::dds;

// Each test on a domain of its own: ctest -j runs them side by side, and on one domain a reader hears the
// other tests' samples.
constexpr int kLateSubscriberDomain = 80;
constexpr int kTypeLookupDomain = 48;
constexpr int kSecureViewDomain = 49;

namespace ros = cpgmatch_msgs::msg::dds_;

domain::StudyState state(int id, domain::StudyStatus status, int completed) {
  domain::StudyState s;
  s.study_id = id;
  s.name = "study-" + std::to_string(id);
  s.status = status;
  s.budget = 40;
  s.completed = completed;
  s.best_cost = 0.25 * id;
  s.best_params = {{"frequency", 1.5}, {"hip_amplitude", 0.3}};
  s.message = "waiting for simulation workers";
  return s;
}

TEST(Ros2Messages, EnumsBecomeTheConstantsOfTheMsgFiles) {
  namespace c = ros::StudyState_Constants;
  // The values the .msg files declare (StudyState.msg: STATUS_RUNNING=0 ... STATUS_STOPPED=4).
  EXPECT_EQ(dds::ros_status(domain::StudyStatus::kRunning), c::STATUS_RUNNING_);
  EXPECT_EQ(dds::ros_status(domain::StudyStatus::kPaused), c::STATUS_PAUSED_);
  EXPECT_EQ(dds::ros_status(domain::StudyStatus::kDone), c::STATUS_DONE_);
  EXPECT_EQ(dds::ros_status(domain::StudyStatus::kFailed), c::STATUS_FAILED_);
  EXPECT_EQ(dds::ros_status(domain::StudyStatus::kStopped), c::STATUS_STOPPED_);
  EXPECT_EQ(c::STATUS_STOPPED_, 4);
  namespace t = ros::TrialRecord_Constants;
  EXPECT_EQ(dds::ros_outcome(domain::Outcome::kFell), t::OUTCOME_FELL_);
  EXPECT_EQ(dds::ros_outcome(domain::Outcome::kError), t::OUTCOME_ERROR_);
  // A trial's worker kind and a worker's kind are one code: TrialRecord's WORKER_* equal Worker's KIND_*.
  EXPECT_EQ(t::WORKER_SIMULATION_, ros::Worker_Constants::KIND_SIMULATION_);
  EXPECT_EQ(t::WORKER_HARDWARE_, ros::Worker_Constants::KIND_HARDWARE_);
}

TEST(Ros2Messages, ATrialCarriesItsParametersAndMeasurementsInSiUnits) {
  domain::TrialRecord t;
  t.study_id = 3;
  t.trial_id = 17;
  t.initial = true;
  t.parameters = {{"frequency", 1.25}, {"knee_amplitude", 0.5}};
  t.report.id.attempt = 2;
  t.report.worker_id = "w1";
  t.report.worker_kind = domain::WorkerKind::kHardware;
  t.report.outcome = domain::Outcome::kFell;
  t.report.summary.cost = 16.5;
  t.report.summary.terms.feedback = 0.125;
  t.report.summary.feedback.early_toeoff = 0.0625;
  t.report.summary.fall_time_s = 3.5;
  t.report.summary.mean_speed_mps = 0.31;
  const ros::TrialRecord_ r = dds::to_ros(t);
  EXPECT_EQ(r.study_id_(), 3u);
  EXPECT_EQ(r.trial_id_(), 17u);
  EXPECT_EQ(r.attempt_(), 2u);
  EXPECT_TRUE(r.initial_());
  ASSERT_EQ(r.param_names_().size(), 2u);
  ASSERT_EQ(r.param_values_().size(), 2u);
  EXPECT_EQ(r.param_names_()[0].to_string(), "frequency");
  EXPECT_DOUBLE_EQ(r.param_values_()[0], 1.25);
  EXPECT_EQ(r.param_names_()[1].to_string(), "knee_amplitude");
  EXPECT_DOUBLE_EQ(r.param_values_()[1], 0.5);
  EXPECT_EQ(r.worker_kind_(), ros::TrialRecord_Constants::WORKER_HARDWARE_);
  EXPECT_EQ(r.outcome_(), ros::TrialRecord_Constants::OUTCOME_FELL_);
  EXPECT_TRUE(r.fell_());
  EXPECT_DOUBLE_EQ(r.cost_(), 16.5);
  EXPECT_DOUBLE_EQ(r.j_feedback_(), 0.125);
  EXPECT_DOUBLE_EQ(r.early_toeoff_fraction_(), 0.0625);
  EXPECT_DOUBLE_EQ(r.fall_time_s_(), 3.5);
  EXPECT_DOUBLE_EQ(r.mean_speed_mps_(), 0.31);
}

// A hexapod's study on the ROS 2 view: its six legs by name in the state and in each trial, each leg's energy in
// that order, and its own search space with units; no Morti leg anywhere.
TEST(Ros2Messages, AHexapodsStateAndTrialsNameItsSixLegsAndItsOwnParameters) {
  const std::vector<std::string> legs = {"L1", "R1", "L2", "R2", "L3", "R3"};
  domain::StudyState st = state(5, domain::StudyStatus::kRunning, 3);
  st.leg_names = legs;
  st.search_space = {{"hip_amplitude", 0.1, 0.45, false, "rad"}, {"overswing", 0.0, 0.5, false, ""}};
  const ros::StudyState_ s = dds::to_ros(st);
  ASSERT_EQ(s.leg_names_().size(), 6u);
  EXPECT_EQ(s.leg_names_()[4].to_string(), "L3");
  ASSERT_EQ(s.search_names_().size(), 2u);
  EXPECT_EQ(s.search_names_()[0].to_string(), "hip_amplitude");
  EXPECT_EQ(s.search_units_()[0].to_string(), "rad");
  EXPECT_EQ(s.search_units_()[1].to_string(), "1") << "dimensionless, as the .msg says";
  EXPECT_DOUBLE_EQ(s.search_high_()[0], 0.45);
  EXPECT_DOUBLE_EQ(s.search_low_()[1], 0.0);

  domain::TrialRecord t;
  t.study_id = 5;
  t.leg_names = legs;
  t.report.summary.energy.hip = PerLeg<JointEnergy>(6);
  t.report.summary.energy.knee = PerLeg<JointEnergy>(6);
  for (std::size_t leg = 0; leg < 6; ++leg) {
    t.report.summary.energy.hip[leg].positive_work_j = 10.0 + leg;
    t.report.summary.energy.knee[leg].electrical_j = 40.0 + leg;
  }
  const ros::TrialRecord_ r = dds::to_ros(t);
  ASSERT_EQ(r.leg_names_().size(), 6u);
  EXPECT_EQ(r.leg_names_()[5].to_string(), "R3");
  ASSERT_EQ(r.leg_hip_positive_work_j_().size(), 6u);
  EXPECT_DOUBLE_EQ(r.leg_hip_positive_work_j_()[4], 14.0);
  EXPECT_DOUBLE_EQ(r.leg_knee_electrical_j_()[5], 45.0);
  for (const auto& name : r.leg_names_()) {
    for (const char* morti : {"FL", "FR", "HL", "HR"}) EXPECT_NE(name.to_string(), morti);
  }
  // A report that measured no energy per leg: every leg named, each value NaN (not measured).
  domain::TrialRecord unmeasured = t;
  unmeasured.report.summary.energy = EnergyMeasures{};
  const ros::TrialRecord_ u = dds::to_ros(unmeasured);
  ASSERT_EQ(u.leg_knee_positive_work_j_().size(), 6u);
  EXPECT_TRUE(std::isnan(u.leg_knee_positive_work_j_()[2]));
}

TEST(Ros2Messages, AWorkerThatLeftIsNotAlive) {
  domain::WorkerAnnouncement w;
  w.worker_id = "node7";
  w.slots = 4;
  w.busy = 3;
  w.accepting = true;
  EXPECT_TRUE(dds::to_ros(w, true).alive_());
  EXPECT_TRUE(dds::to_ros(w, true).accepting_());
  EXPECT_FALSE(dds::to_ros(w, false).alive_());
  EXPECT_FALSE(dds::to_ros(w, false).accepting_());
  EXPECT_EQ(dds::to_ros(w, false).slots_(), 4u);
}

// A ROS 2 subscriber as `ros2 topic echo /cpgmatch/study_state` creates it (rmw_fastrtps: topic
// rt/cpgmatch/study_state, type cpgmatch_msgs::msg::dds_::StudyState_, reliable, transient local, KEEP_LAST).
struct LateRosSubscriber {
  explicit LateRosSubscriber(dds::Participant& p) {
    participant = const_cast<fdds::DomainParticipant*>(p.subscriber()->get_participant());
    fdds::TypeSupport type(new ros::StudyState_PubSubType());
    type.register_type(participant);
    topic = participant->create_topic("rt/cpgmatch/study_state", type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    fdds::DataReaderQos qos = fdds::DATAREADER_QOS_DEFAULT;
    qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
    qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    qos.history().depth = 10;
    subscriber = p.subscriber();
    reader = subscriber->create_datareader(topic, qos);
  }
  ~LateRosSubscriber() {
    subscriber->delete_datareader(reader);
    participant->delete_topic(topic);
  }
  // Study id -> the last state read of it, for the studies below 10, after waiting up to `timeout` for
  // `studies` of them.
  std::map<std::uint32_t, ros::StudyState_> read(std::size_t studies, std::chrono::milliseconds timeout) {
    std::map<std::uint32_t, ros::StudyState_> got;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (got.size() < studies && std::chrono::steady_clock::now() < deadline) {
      ros::StudyState_ s;
      fdds::SampleInfo info;
      while (reader->take_next_sample(&s, &info) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
        if (info.valid_data && s.study_id_() < 10) got[s.study_id_()] = s;
      }
      std::this_thread::sleep_for(20ms);
    }
    return got;
  }
  fdds::DomainParticipant* participant = nullptr;
  fdds::Subscriber* subscriber = nullptr;
  fdds::Topic* topic = nullptr;
  fdds::DataReader* reader = nullptr;
};

TEST(Ros2View, ALateSubscriberGetsTheLatestStateOfEveryOpenStudy) {
  dds::Participant optimizer(dds::ParticipantConfig::basic(kLateSubscriberDomain, "test-ros2-optimizer", true));
  dds::Ros2View view(optimizer, false);
  // Study 1 changes after study 2 did: with one unkeyed writer a late subscriber would see study 1 only.
  ASSERT_TRUE(view.publish_state(state(1, domain::StudyStatus::kRunning, 3)));
  ASSERT_TRUE(view.publish_state(state(2, domain::StudyStatus::kRunning, 5)));
  ASSERT_TRUE(view.publish_state(state(1, domain::StudyStatus::kRunning, 4)));
  ASSERT_TRUE(view.publish_state(state(1, domain::StudyStatus::kPaused, 4)));
  // Finished before the service started (first seen closed): not part of the live view.
  ASSERT_TRUE(view.publish_state(state(9, domain::StudyStatus::kDone, 40)));

  dds::Participant ros2_node(dds::ParticipantConfig::basic(kLateSubscriberDomain, "test-ros2-node", true));
  {
    LateRosSubscriber late(ros2_node);
    const auto got = late.read(2, 10s);
    ASSERT_EQ(got.size(), 2u) << "a late subscriber must get both open studies";
    EXPECT_EQ(got.at(1).completed_(), 4u);
    EXPECT_EQ(got.at(1).status_(), ros::StudyState_Constants::STATUS_PAUSED_);
    EXPECT_EQ(got.at(1).name_().to_string(), "study-1");
    EXPECT_EQ(got.at(2).completed_(), 5u);
    EXPECT_DOUBLE_EQ(got.at(2).best_cost_(), 0.5);
    ASSERT_EQ(got.at(2).best_param_names_().size(), 2u);
    EXPECT_EQ(got.at(2).best_param_names_()[1].to_string(), "hip_amplitude");
    EXPECT_DOUBLE_EQ(got.at(2).best_param_values_()[1], 0.3);
    EXPECT_EQ(got.count(9), 0u);
  }
  // Study 2's records leave (retire_trial): so does its state, and the next late subscriber sees study 1 only.
  view.retire_study(2);
  LateRosSubscriber later(ros2_node);
  const auto got = later.read(2, 3s);
  EXPECT_EQ(got.size(), 1u);
  EXPECT_EQ(got.count(1), 1u);
}

// What eProsima DDS Record & Replay does with a topic it discovers: it takes the writer's TypeInformation and
// asks the writer's participant for the types (TypeLookup), then builds the type to record with.
struct TypeDiscoverer : fdds::DomainParticipantListener {
  std::mutex mutex;
  std::map<std::string, std::string> type_of_topic;                     // announced in discovery
  std::map<std::string, eprosima::fastrtps::types::TypeInformation> info;  // by type name
  std::map<std::string, eprosima::fastrtps::types::DynamicType_ptr> built;
  void on_type_information_received(fdds::DomainParticipant*, const eprosima::fastrtps::string_255 topic,
                                    const eprosima::fastrtps::string_255 type,
                                    const eprosima::fastrtps::types::TypeInformation& information) override {
    std::lock_guard<std::mutex> lock(mutex);
    type_of_topic[topic.to_string()] = type.to_string();
    info[type.to_string()] = information;
  }
};

template <class F>
bool eventually(F condition, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!condition()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(20ms);
  }
  return true;
}

// The recorder's side, in a process of its own (as DDS Record & Replay is): waits for the TypeInformation of
// rt/cpgmatch/study_state, fetches the type by TypeLookup and checks it. Exit code 0: learned; 1: nothing
// announced; 2: the announced type name is wrong; 3: TypeLookup delivered no type; 4: a type of another shape.
int learn_state_type_as_a_recorder() {
  TypeDiscoverer recorder;
  fdds::DomainParticipantQos qos = fdds::PARTICIPANT_QOS_DEFAULT;
  qos.wire_protocol().builtin.typelookup_config.use_client = true;
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  fdds::DomainParticipant* participant = factory->create_participant(kTypeLookupDomain, qos, &recorder, fdds::StatusMask::none());
  if (participant == nullptr) return 1;
  const std::string state_type = "cpgmatch_msgs::msg::dds_::StudyState_";
  int result = 0;
  eprosima::fastrtps::types::TypeInformation information;
  auto locked = [&](auto f) {
    std::lock_guard<std::mutex> lock(recorder.mutex);
    return f();
  };
  if (!eventually([&] { return locked([&] { return recorder.type_of_topic.count("rt/cpgmatch/study_state") > 0; }); },
                  15s)) {
    result = 1;
  } else if (locked([&] { return recorder.type_of_topic["rt/cpgmatch/study_state"]; }) != state_type) {
    result = 2;
  } else {
    information = locked([&] { return recorder.info[state_type]; });
    std::function<void(const std::string&, const eprosima::fastrtps::types::DynamicType_ptr)> on_type =
        [&](const std::string& name, const eprosima::fastrtps::types::DynamicType_ptr type) {
          locked([&] { return recorder.built[name] = type; });
        };
    participant->register_remote_type(information, state_type, on_type);
    if (!eventually([&] { return locked([&] { return recorder.built.count(state_type) > 0; }); }, 15s)) {
      result = 3;
    } else {
      // The fields of StudyState.msg: 24, and the robot's legs and search space appended (5 parallel arrays).
      result = locked([&] { return recorder.built[state_type]->get_members_count(); }) == 29u ? 0 : 4;
    }
  }
  participant->delete_contained_entities();
  factory->delete_participant(participant);
  return result;
}

TEST(Ros2View, WithTypeInformationARecorderLearnsTheTypesOfTheTopics) {
  // Forked before this process touches DDS (ctest runs each test in a process of its own): in a process that
  // has the types already, Fast DDS asks for none.
  const pid_t recorder = fork();
  ASSERT_GE(recorder, 0);
  if (recorder == 0) _exit(learn_state_type_as_a_recorder());
  dds::ParticipantConfig config = dds::ParticipantConfig::basic(kTypeLookupDomain, "test-ros2-typed-optimizer", false);
  config.serve_type_lookup = true;
  dds::Participant optimizer(config);
  dds::Ros2View view(optimizer, true);
  ASSERT_TRUE(view.publish_state(state(77, domain::StudyStatus::kRunning, 1)));
  int status = 0;
  ASSERT_EQ(waitpid(recorder, &status, 0), recorder);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "1: no TypeInformation announced, 2: wrong type name, 3: TypeLookup "
                                       "delivered no type, 4: a type of another shape";
}

// With DDS-Security (a keystore from deploy/make-study-pki.sh) the optimizer's enclave may publish the view and
// the viewer's may read it. Two identities need two processes: the viewer is forked before any DDS.
TEST(Ros2View, UnderDdsSecurityTheViewerEnclaveReadsWhatTheOptimizerPublishes) {
  const std::filesystem::path keystore =
      std::filesystem::temp_directory_path() / ("cpgmatch-ros2-ks-" + std::to_string(getpid()));
  const std::string make = std::string(CPGMATCH_SOURCE_DIR) + "/deploy/make-study-pki.sh " + keystore.string() +
                           " --days 1 >/dev/null";
  ASSERT_EQ(std::system(make.c_str()), 0) << make;
  const pid_t viewer = fork();
  ASSERT_GE(viewer, 0);
  if (viewer == 0) {
    dds::select_security(dds::SecuritySelection{keystore, "viewer"});
    dds::Participant node(dds::ParticipantConfig::basic(kSecureViewDomain, "test-ros2-viewer", true));
    LateRosSubscriber late(node);
    const auto got = late.read(1, 20s);
    _exit(got.count(5) == 1 && got.at(5).completed_() == 7 ? 0 : 1);
  }
  dds::select_security(dds::SecuritySelection{keystore, "optimizer"});
  {
    dds::Participant optimizer(dds::ParticipantConfig::basic(kSecureViewDomain, "test-ros2-secure-optimizer", true));
    dds::Ros2View view(optimizer, false);  // throws if the optimizer's permissions lacked the rt/ topics
    ASSERT_TRUE(view.publish_state(state(5, domain::StudyStatus::kRunning, 7)));
    int status = 0;
    ASSERT_EQ(waitpid(viewer, &status, 0), viewer);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the viewer enclave read no state of study 5";
  }
  dds::select_security({});
  std::filesystem::remove_all(keystore);
}

// ---- ROS 2's environment variables as defaults --------------------------------------------------------

// Sets (or, with nullptr, unsets) environment variables for one test and restores them after.
class ScopedEnv {
 public:
  ScopedEnv(std::initializer_list<std::pair<const char*, const char*>> values) {
    for (const auto& [name, value] : values) {
      const char* old = std::getenv(name);
      saved_.emplace_back(name, old ? std::optional<std::string>(old) : std::nullopt);
      value ? setenv(name, value, 1) : unsetenv(name);
    }
  }
  ~ScopedEnv() {
    for (const auto& [name, value] : saved_) value ? setenv(name.c_str(), value->c_str(), 1) : unsetenv(name.c_str());
  }

 private:
  std::vector<std::pair<std::string, std::optional<std::string>>> saved_;
};

std::string input_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(Ros2Environment, RosDomainIdIsTheDefaultAfterCpgmatchDomain) {
  {
    ScopedEnv env{{"CPGMATCH_DOMAIN", nullptr}, {"ROS_DOMAIN_ID", "42"}};
    EXPECT_EQ(dds::default_domain(), 42);
  }
  {
    ScopedEnv env{{"CPGMATCH_DOMAIN", "7"}, {"ROS_DOMAIN_ID", "42"}};
    EXPECT_EQ(dds::default_domain(), 7);
  }
  {
    ScopedEnv env{{"CPGMATCH_DOMAIN", nullptr}, {"ROS_DOMAIN_ID", ""}};
    EXPECT_EQ(dds::default_domain(), 0);
  }
}

TEST(Ros2Environment, ABadRosDomainIdNamesTheVariable) {
  ScopedEnv env{{"CPGMATCH_DOMAIN", nullptr}, {"ROS_DOMAIN_ID", "twelve"}};
  EXPECT_EQ(input_error([] { dds::default_domain(); }), "ROS_DOMAIN_ID: 'twelve' is not a domain id");
  ScopedEnv too_big{{"ROS_DOMAIN_ID", "233"}};
  EXPECT_NE(input_error([] { dds::default_domain(); }).find("ROS_DOMAIN_ID: domain id 233 is outside 0..232"),
            std::string::npos);
}

runtime::DdsFlags flags(const std::string& keystore = "", const std::string& enclave = "") {
  runtime::DdsFlags f;
  f.keystore = keystore;
  f.enclave = enclave;
  f.default_enclave = "optimizer";
  return f;
}

TEST(Ros2Environment, KeystoreAndEnclavePrecedenceIsFlagThenCpgmatchThenRos) {
  ScopedEnv env{{"CPGMATCH_KEYSTORE", nullptr},
                {"ROS_SECURITY_KEYSTORE", "/ros/ks"},
                {"ROS_SECURITY_ENABLE", "true"},
                {"ROS_SECURITY_ENCLAVE_OVERRIDE", "/viewer"}};
  runtime::SecurityChoice c = runtime::choose_security(flags());
  EXPECT_EQ(c.keystore, "/ros/ks");
  EXPECT_EQ(c.keystore_from, "ROS_SECURITY_KEYSTORE");
  EXPECT_EQ(c.enclave, "viewer");  // ROS 2's "/viewer" is the enclave folder "viewer"
  EXPECT_EQ(c.enclave_from, "ROS_SECURITY_ENCLAVE_OVERRIDE");
  {
    ScopedEnv ours{{"CPGMATCH_KEYSTORE", "/ours"}};
    c = runtime::choose_security(flags());
    EXPECT_EQ(c.keystore, "/ours");
    EXPECT_EQ(c.keystore_from, "CPGMATCH_KEYSTORE");
  }
  c = runtime::choose_security(flags("/flag", "operator"));
  EXPECT_EQ(c.keystore, "/flag");
  EXPECT_EQ(c.keystore_from, "");
  EXPECT_EQ(c.enclave, "operator");
  EXPECT_EQ(c.enclave_from, "");
}

TEST(Ros2Environment, RosSecurityKeystoreCountsOnlyWithRosSecurityEnable) {
  for (const char* enable : {static_cast<const char*>(nullptr), "false", "1"}) {
    ScopedEnv env{{"CPGMATCH_KEYSTORE", nullptr},
                  {"ROS_SECURITY_KEYSTORE", "/ros/ks"},
                  {"ROS_SECURITY_ENABLE", enable},
                  {"ROS_SECURITY_ENCLAVE_OVERRIDE", nullptr}};
    const runtime::SecurityChoice c = runtime::choose_security(flags());
    EXPECT_EQ(c.keystore, "") << "ROS_SECURITY_ENABLE=" << (enable ? enable : "(unset)");
    EXPECT_EQ(c.enclave, "optimizer");
  }
}

TEST(Ros2Environment, ABadRosKeystoreOrEnclaveNamesTheVariable) {
  {
    ScopedEnv env{{"CPGMATCH_KEYSTORE", nullptr},
                  {"ROS_SECURITY_KEYSTORE", "/no/such/keystore"},
                  {"ROS_SECURITY_ENABLE", "true"},
                  {"ROS_SECURITY_ENCLAVE_OVERRIDE", nullptr}};
    const std::string why = input_error([] { runtime::apply_dds_flags(flags()); });
    EXPECT_NE(why.find("'/no/such/keystore' is not a folder"), std::string::npos) << why;
    EXPECT_NE(why.find("$ROS_SECURITY_KEYSTORE"), std::string::npos) << why;
  }
  {
    ScopedEnv env{{"CPGMATCH_KEYSTORE", "/tmp"},
                  {"ROS_SECURITY_KEYSTORE", nullptr},
                  {"ROS_SECURITY_ENCLAVE_OVERRIDE", "/cpgmatch/viewer"}};  // a nested ROS 2 enclave: not ours
    const std::string why = input_error([] { runtime::apply_dds_flags(flags()); });
    EXPECT_NE(why.find("'cpgmatch/viewer' is not an enclave name"), std::string::npos) << why;
    EXPECT_NE(why.find("$ROS_SECURITY_ENCLAVE_OVERRIDE ('/cpgmatch/viewer')"), std::string::npos) << why;
  }
}

}  // namespace
}  // namespace cpgmatch

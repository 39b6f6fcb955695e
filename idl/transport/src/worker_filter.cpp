#include "cpgmatch/dds/worker_filter.hpp"

#include <cstdint>
#include <cstring>

namespace cpgmatch::dds {

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::types::ReturnCode_t;

namespace {

thread_local const std::string* t_addressed_to = nullptr;

// The type this filter understands: the one fastddsgen names for msg::Candidate.
constexpr const char* kCandidateType = "cpgmatch::msg::Candidate";

// Fast DDS's IContentFilter has no virtual destructor; the factory deletes the filters it made as
// WorkerIdFilter, never through the base.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnon-virtual-dtor"
class WorkerIdFilter final : public fdds::IContentFilter {
 public:
  explicit WorkerIdFilter(std::string worker_id) : worker_id_(std::move(worker_id)) {}
  virtual ~WorkerIdFilter() = default;
  void set(std::string worker_id) { worker_id_ = std::move(worker_id); }

  bool evaluate(const SerializedPayload& payload, const FilterSampleInfo&, const GUID_t&) const override {
    // A dispose in progress names its worker (see AddressedTo); its payload holds no worker id.
    if (const std::string* to = AddressedTo::current()) return *to == worker_id_;
    std::string id;
    // Unreadable: let it through; the worker checks the worker id again when it reads the sample.
    if (!candidate_worker_id(payload.data, payload.length, id)) return true;
    return id == worker_id_;
  }

 private:
  std::string worker_id_;
};
#pragma GCC diagnostic pop

std::uint32_t read_u32(const unsigned char* p, bool little_endian) {
  return little_endian ? std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 |
                             std::uint32_t(p[3]) << 24
                       : std::uint32_t(p[3]) | std::uint32_t(p[2]) << 8 | std::uint32_t(p[1]) << 16 |
                             std::uint32_t(p[0]) << 24;
}

}  // namespace

AddressedTo::AddressedTo(const std::string& worker_id) { t_addressed_to = &worker_id; }
AddressedTo::~AddressedTo() { t_addressed_to = nullptr; }
const std::string* AddressedTo::current() { return t_addressed_to; }

bool candidate_worker_id(const unsigned char* data, std::size_t length, std::string& worker_id) {
  // XCDR1 of the @final struct Candidate (idl/cpgmatch_msgs.idl): a 4-byte encapsulation header
  // (byte 1: 0 big endian, 1 little endian), then, aligned from the body's start, uint64 store_id (0),
  // uint32 study_id (8), trial_id (12), attempt (16), then worker_id as uint32 length with the
  // terminating NUL (20) and its characters (24). The layout is pinned by a unit test against the
  // generated serializer (Transport.WorkerFilterReadsTheSerializedWorkerId).
  constexpr std::size_t kHeader = 4, kLengthAt = kHeader + 20, kCharsAt = kHeader + 24;
  if (data == nullptr || length < kCharsAt) return false;
  if (data[0] != 0 || data[1] > 1) return false;  // CDR_BE / CDR_LE only (the type is @final)
  const std::uint32_t n = read_u32(data + kLengthAt, data[1] == 1);
  if (n == 0 || n > 65 || kCharsAt + n > length || data[kCharsAt + n - 1] != 0) return false;
  worker_id.assign(reinterpret_cast<const char*>(data + kCharsAt), n - 1);
  return true;
}

WorkerIdFilterFactory& WorkerIdFilterFactory::instance() {
  static WorkerIdFilterFactory factory;
  return factory;
}

ReturnCode_t WorkerIdFilterFactory::create_content_filter(const char*, const char* type_name,
                                                          const fdds::TopicDataType*, const char* filter_expression,
                                                          const ParameterSeq& filter_parameters,
                                                          fdds::IContentFilter*& filter_instance) {
  if (type_name == nullptr || std::strcmp(type_name, kCandidateType) != 0) return ReturnCode_t::RETCODE_BAD_PARAMETER;
  // Fast DDS passes a null expression when only the parameters change.
  if (filter_expression != nullptr && std::strcmp(filter_expression, kWorkerIdFilterExpression) != 0) {
    return ReturnCode_t::RETCODE_BAD_PARAMETER;
  }
  if (filter_parameters.length() != 1 || filter_parameters[0] == nullptr) return ReturnCode_t::RETCODE_BAD_PARAMETER;
  std::string id = filter_parameters[0];
  if (filter_instance != nullptr) {
    static_cast<WorkerIdFilter*>(filter_instance)->set(std::move(id));
  } else {
    filter_instance = new WorkerIdFilter(std::move(id));
  }
  return ReturnCode_t::RETCODE_OK;
}

ReturnCode_t WorkerIdFilterFactory::delete_content_filter(const char*, fdds::IContentFilter* filter_instance) {
  delete static_cast<WorkerIdFilter*>(filter_instance);
  return ReturnCode_t::RETCODE_OK;
}

}  // namespace cpgmatch::dds

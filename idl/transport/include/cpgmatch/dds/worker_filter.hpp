// The writer-side filter that sends each candidate only to the worker it is addressed to (docs/dds.md,
// "Each worker hears only its own candidates").
//
// A custom Fast DDS content filter (IContentFilterFactory) instead of DDS-SQL: the worker's reader on
// cpgmatch/candidates announces the filter class kWorkerIdFilterClass with its worker id as the one
// parameter; the optimizer's participant has the same factory registered, so its writer evaluates the
// filter for every matched worker before sending and sends the sample to the one worker it is for. The
// evaluation reads the CDR prefix of the sample (the key, the attempt, the worker id) in place: no
// DynamicData, no exceptions, about 50 ns a reader.
//
// Key-only samples (the optimizer's dispose of a candidate, which is the report's acknowledgement) carry no
// worker id in their payload. The thread that unregisters a candidate names its worker for the length of
// the call (AddressedTo, set by dds::Writer<msg::Candidate>::unregister, see participant.hpp): Fast DDS
// evaluates writer-side filters synchronously in the writing thread, so the filter then passes the dispose
// to that worker only. A key-only sample without a name (a writer that did not say) passes every filter,
// which is what every worker received before this filter existed.
#pragma once

#include <string>

#include <fastdds/dds/topic/IContentFilterFactory.hpp>

namespace cpgmatch::dds {

// The filter class announced in the reader's ContentFilterProperty (at most 255 characters).
inline constexpr const char* kWorkerIdFilterClass = "CPGMATCH_WORKER_ID";
// The expression the reader announces; the filter has one form, the parameter is the worker id.
inline constexpr const char* kWorkerIdFilterExpression = "worker_id = %0";

// The worker the calling thread's next key-only candidate sample (unregister/dispose) is addressed to,
// for as long as this object lives. Nested use is not supported (one write at a time per thread).
class AddressedTo {
 public:
  explicit AddressedTo(const std::string& worker_id);
  ~AddressedTo();
  AddressedTo(const AddressedTo&) = delete;
  AddressedTo& operator=(const AddressedTo&) = delete;
  // The worker named by the innermost AddressedTo on this thread; nullptr when none.
  static const std::string* current();
};

// The worker id of a serialized msg::Candidate (CDR, either endianness), read without deserialising the
// rest; false when the payload is too short to hold one (a key-only sample) or malformed.
bool candidate_worker_id(const unsigned char* data, std::size_t length, std::string& worker_id);

// One factory per process, registered on every participant (participant.cpp); never deleted through its
// base (whose destructor Fast DDS leaves non-virtual).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnon-virtual-dtor"
class WorkerIdFilterFactory final : public eprosima::fastdds::dds::IContentFilterFactory {
 public:
  static WorkerIdFilterFactory& instance();
  ReturnCode_t create_content_filter(const char* filter_class_name, const char* type_name,
                                     const eprosima::fastdds::dds::TopicDataType* data_type,
                                     const char* filter_expression, const ParameterSeq& filter_parameters,
                                     eprosima::fastdds::dds::IContentFilter*& filter_instance) override;
  ReturnCode_t delete_content_filter(const char* filter_class_name,
                                     eprosima::fastdds::dds::IContentFilter* filter_instance) override;
};
#pragma GCC diagnostic pop

}  // namespace cpgmatch::dds

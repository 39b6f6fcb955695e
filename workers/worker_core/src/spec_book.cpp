#include "cpgmatch/worker/spec_book.hpp"

#include <fmt/format.h>

namespace cpgmatch::worker {

SpecBook::Lookup SpecBook::find(std::uint64_t key, std::chrono::milliseconds wait) {
  if (key == 0) return {nullptr, "the candidate names no study spec (spec_key 0: an optimizer from before specs?)"};
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (const auto it = parsed_.find(key); it != parsed_.end()) return {it->second, ""};
  }
  const std::optional<ReceivedSpec> received = link_.spec(key, wait);
  if (!received) {
    return {nullptr, fmt::format("study spec {} not received on cpgmatch/study_specs within {} ms",
                                 study::spec_key_hex(key), wait.count())};
  }
  if (received->objective_version != objective_version_) {
    return {nullptr, fmt::format("study spec {} is for objective version {}; this worker computes version {}",
                                 study::spec_key_hex(key), received->objective_version, objective_version_)};
  }
  // Its content must be what its key and hash say before anything parses it: the optimizer sends exactly
  // its canonical JSON, so anything else is a forgery or a corruption.
  const std::string content_hash = study::sha256_hex(received->json);
  if (content_hash != received->sha256 || content_hash.substr(0, 16) != study::spec_key_hex(key)) {
    return {nullptr, fmt::format("study spec {}: its content hashes to {}, not to its key and hash",
                                 study::spec_key_hex(key), content_hash.substr(0, 16))};
  }
  std::shared_ptr<const study::StudySpec> spec;
  try {
    spec = std::make_shared<const study::StudySpec>(
        study::StudySpec::from_json_text(received->json, "spec " + study::spec_key_hex(key)));
  } catch (const std::exception& e) {
    return {nullptr, fmt::format("study spec {} does not load here: {}", study::spec_key_hex(key), e.what())};
  }
  if (spec->key() != key || spec->sha256() != received->sha256) {
    return {nullptr, fmt::format("study spec {}: its content hashes to {}, not to its key", study::spec_key_hex(key),
                                 spec->sha256())};
  }
  if (static_cast<int>(spec->objective_version()) != objective_version_) {
    return {nullptr, fmt::format("study spec {} says objective version {}; this worker computes version {}",
                                 study::spec_key_hex(key), spec->objective_version(), objective_version_)};
  }
  std::lock_guard<std::mutex> lock(mutex_);
  parsed_[key] = spec;
  return {spec, ""};
}

}  // namespace cpgmatch::worker

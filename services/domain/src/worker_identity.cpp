#include "cpgmatch/domain/worker_identity.hpp"

namespace cpgmatch::domain {

std::uint64_t worker_key(const std::string& worker_id) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : worker_id) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

bool worker_id_belongs_to(const std::string& worker_id, const std::string& common_name) {
  if (common_name.empty()) return false;
  if (worker_id == common_name) return true;
  return worker_id.size() > common_name.size() + 1 && worker_id.compare(0, common_name.size(), common_name) == 0 &&
         worker_id[common_name.size()] == '/';
}

}  // namespace cpgmatch::domain

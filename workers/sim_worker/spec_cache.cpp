#include "spec_cache.hpp"

#include <algorithm>

namespace cpgmatch::worker {

std::shared_ptr<const study::StudySpec> SpecCache::find(std::uint64_t key) {
  const auto it = std::find_if(specs_.begin(), specs_.end(), [key](const auto& s) { return s->key() == key; });
  if (it == specs_.end()) return nullptr;
  std::rotate(it, it + 1, specs_.end());  // to the back: most recently used
  return specs_.back();
}

void SpecCache::keep(std::shared_ptr<const study::StudySpec> spec) {
  if (find(spec->key())) return;
  specs_.push_back(std::move(spec));
  if (specs_.size() > capacity_) specs_.erase(specs_.begin());
}

}  // namespace cpgmatch::worker

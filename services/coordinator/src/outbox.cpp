#include "cpgmatch/service/outbox.hpp"

namespace cpgmatch::service {

void DeferredOutbox::release() {
  holding_ = false;
  auto held = std::move(held_);
  held_.clear();
  for (auto& send : held) send(target_);
}

void DeferredOutbox::discard() {
  holding_ = false;
  held_.clear();
}

}  // namespace cpgmatch::service

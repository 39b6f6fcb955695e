// The replies to recent commands, by (client_id, correlation_id). A client re-sends a command whose reply it
// did not get (commands travel at least once), and gets the same reply again instead of a second execution
// (a second study, say). Keeps the last `capacity` replies; an older command re-sent after that many others is
// executed again, which for the CLI's seconds-long retry window never happens.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <utility>

#include "cpgmatch/domain/command.hpp"

namespace cpgmatch::service {

class ReplyCache {
 public:
  explicit ReplyCache(std::size_t capacity = 1024) : capacity_(capacity) {}

  std::optional<domain::CommandReply> find(const domain::StudyCommand& command) const {
    const auto it = replies_.find(key_of(command));
    return it == replies_.end() ? std::nullopt : std::optional<domain::CommandReply>(it->second);
  }
  void remember(const domain::StudyCommand& command, const domain::CommandReply& reply) {
    const Key key = key_of(command);
    if (replies_.insert_or_assign(key, reply).second) order_.push_back(key);
    if (order_.size() > capacity_) {
      replies_.erase(order_.front());
      order_.pop_front();
    }
  }
  std::size_t size() const { return replies_.size(); }

 private:
  using Key = std::pair<std::string, std::uint64_t>;
  static Key key_of(const domain::StudyCommand& c) { return {c.client_id, c.correlation_id}; }
  std::size_t capacity_;
  std::map<Key, domain::CommandReply> replies_;
  std::deque<Key> order_;  // oldest first
};

}  // namespace cpgmatch::service

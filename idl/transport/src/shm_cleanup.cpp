#include "cpgmatch/dds/shm_cleanup.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <string>
#include <system_error>
#include <vector>

namespace cpgmatch::dds {

namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// "fastrtps_" + 16 lower-case hex digits: a data segment's name.
bool is_segment_name(const std::string& base) {
  const std::string prefix = "fastrtps_";
  if (base.size() != prefix.size() + 16 || base.compare(0, prefix.size(), prefix) != 0) return false;
  for (std::size_t i = prefix.size(); i < base.size(); ++i) {
    const char c = base[i];
    if (!(std::isdigit(static_cast<unsigned char>(c)) || (c >= 'a' && c <= 'z'))) return false;
  }
  return true;
}

// "fastrtps_port" + 1 to 5 digits: a port's segment.
bool is_port_name(const std::string& base) {
  const std::string prefix = "fastrtps_port";
  if (base.size() <= prefix.size() || base.size() > prefix.size() + 5 || base.compare(0, prefix.size(), prefix) != 0) {
    return false;
  }
  for (std::size_t i = prefix.size(); i < base.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(base[i]))) return false;
  }
  return true;
}

enum class Owner { kAlive, kDead, kUnknown };

// Whether a lock file's owner is alive: it holds an exclusive flock on it for its whole life.
Owner owner_of(const std::filesystem::path& lock_file) {
  const int fd = ::open(lock_file.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) return Owner::kUnknown;  // not ours to judge (another user's, or gone meanwhile)
  const bool free = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  ::close(fd);  // releases the probe's lock
  return free ? Owner::kDead : Owner::kAlive;
}

// True when the file is gone afterwards (removed now, or already gone).
bool remove_quietly(const std::filesystem::path& p) {
  std::error_code error;
  std::filesystem::remove(p, error);
  return !error;
}

}  // namespace

ShmCleanup remove_dead_shm_segments(const std::filesystem::path& dir) {
  ShmCleanup result;
  std::error_code error;
  std::filesystem::directory_iterator it(dir, error);
  if (error) return result;
  std::vector<std::filesystem::path> locks;
  for (const auto& entry : it) {
    const std::string name = entry.path().filename().string();
    if (ends_with(name, "_el") || ends_with(name, "_sl")) locks.push_back(entry.path());
  }
  for (const auto& lock : locks) {
    const std::string name = lock.filename().string();
    const std::string base = name.substr(0, name.size() - 3);
    const bool segment = is_segment_name(base), port = is_port_name(base);
    if (!segment && !port) continue;
    // A process creates its lock file and then locks it: a file younger than a few seconds may be one
    // whose owner is starting right now.
    std::error_code age_error;
    const auto modified = std::filesystem::last_write_time(lock, age_error);
    if (age_error || std::filesystem::file_time_type::clock::now() - modified < std::chrono::seconds(5)) continue;
    const Owner owner = owner_of(lock);
    if (owner == Owner::kAlive) ++result.in_use;
    if (owner != Owner::kDead) continue;
    if (!remove_quietly(dir / base) || !remove_quietly(lock)) continue;  // another user's, in sticky /dev/shm
    if (port) {
      remove_quietly(dir / ("sem." + base + "_mutex"));  // the port's named semaphore
      ++result.ports_removed;
    } else {
      ++result.segments_removed;
    }
  }
  return result;
}

}  // namespace cpgmatch::dds

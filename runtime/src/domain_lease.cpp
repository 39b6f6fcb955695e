#include "cpgmatch/runtime/domain_lease.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>

namespace cpgmatch::runtime {
namespace {

// Opens (creating if needed) a domain's lock file. nullopt: the file exists but this user may not open it
// (another user's file under a umask of 077, or fs.protected_regular in a sticky /tmp): that domain is
// treated as taken. Throws for anything else, naming the file.
std::optional<int> open_lock_file(const std::filesystem::path& file) {
  // Read-only is enough for flock, and lets another user's run lock a file this user created: a domain is
  // host-wide on loopback, so every user's runs share one set of lock files. An existing file is opened
  // without O_CREAT, which fs.protected_regular would refuse for another user's file in a sticky directory.
  for (int attempt = 0; attempt < 2; ++attempt) {
    int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd >= 0) return fd;
    if (errno == EACCES || errno == EPERM) return std::nullopt;
    if (errno != ENOENT) break;
    fd = ::open(file.c_str(), O_RDONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd >= 0) {
      ::fchmod(fd, 0644);  // readable by every user whatever this process's umask
      return fd;
    }
    if (errno != EEXIST) break;  // EEXIST: another run created it just now; open it on the next attempt
  }
  throw std::runtime_error(fmt::format("cannot create the domain lock file {}: {} (set --domain to choose one)",
                                       file.string(), std::strerror(errno)));
}

// The lock is this run's only if the file still is the one locked: a file deleted while held (by hand, or
// by a temp cleaner) and created again by another run would otherwise give two runs one domain.
bool still_the_same_file(int fd, const std::filesystem::path& file) {
  struct stat held {}, current {};
  return ::fstat(fd, &held) == 0 && ::stat(file.c_str(), &current) == 0 && held.st_dev == current.st_dev &&
         held.st_ino == current.st_ino;
}

}  // namespace

DomainLease DomainLease::acquire(int first, int count, int start_offset, const std::filesystem::path& lock_dir) {
  if (count <= 0) throw std::invalid_argument("DomainLease::acquire: count must be positive");
  const int start = ((start_offset % count) + count) % count;
  for (int i = 0; i < count; ++i) {
    const int domain = first + (start + i) % count;
    const std::filesystem::path file = lock_dir / fmt::format("cpgmatch-domain-{}.lock", domain);
    const std::optional<int> fd = open_lock_file(file);
    if (!fd) continue;
    if (::flock(*fd, LOCK_EX | LOCK_NB) == 0) {
      if (still_the_same_file(*fd, file)) return DomainLease(domain, *fd);
      ::close(*fd);
      continue;
    }
    const int err = errno;
    ::close(*fd);
    if (err != EWOULDBLOCK) {
      throw std::runtime_error(fmt::format("cannot lock {}: {}", file.string(), std::strerror(err)));
    }
  }
  throw std::runtime_error(fmt::format("all {} private DDS domains {}-{} are in use by other local studies "
                                       "(lock files in {}); set --domain to choose one",
                                       count, first, first + count - 1, lock_dir.string()));
}

std::filesystem::path DomainLease::default_lock_dir() { return "/tmp"; }

DomainLease::DomainLease(DomainLease&& other) noexcept
    : domain_(std::exchange(other.domain_, -1)), fd_(std::exchange(other.fd_, -1)) {}

DomainLease& DomainLease::operator=(DomainLease&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    domain_ = std::exchange(other.domain_, -1);
    fd_ = std::exchange(other.fd_, -1);
  }
  return *this;
}

DomainLease::~DomainLease() {
  if (fd_ >= 0) ::close(fd_);  // closing the only descriptor releases the flock
}

}  // namespace cpgmatch::runtime

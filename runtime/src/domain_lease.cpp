#include "cpgmatch/runtime/domain_lease.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>

namespace cpgmatch::runtime {

DomainLease DomainLease::acquire(int first, int count, int start_offset, const std::filesystem::path& lock_dir) {
  if (count <= 0) throw std::invalid_argument("DomainLease::acquire: count must be positive");
  const int start = ((start_offset % count) + count) % count;
  for (int i = 0; i < count; ++i) {
    const int domain = first + (start + i) % count;
    const std::filesystem::path file = lock_dir / fmt::format("cpgmatch-domain-{}.lock", domain);
    // Read-only is enough for flock, and lets another user's run lock a file this user created: a domain is
    // host-wide on loopback, so every user's runs share one set of lock files.
    const int fd = ::open(file.c_str(), O_RDONLY | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      throw std::runtime_error(fmt::format("cannot create the domain lock file {}: {} (set --domain to choose one)",
                                           file.string(), std::strerror(errno)));
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return DomainLease(domain, fd);
    const int err = errno;
    ::close(fd);
    if (err != EWOULDBLOCK) {
      throw std::runtime_error(fmt::format("cannot lock {}: {}", file.string(), std::strerror(err)));
    }
  }
  throw std::runtime_error(fmt::format("all {} private DDS domains {}-{} are in use by other local studies "
                                       "(lock files in {}); set --domain to choose one",
                                       count, first, first + count - 1, lock_dir.string()));
}

std::filesystem::path DomainLease::default_lock_dir() { return std::filesystem::temp_directory_path(); }

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

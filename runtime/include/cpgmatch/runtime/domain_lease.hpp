// A DDS domain id of this host's own for a local study (`cpgmatch study run`, `reproduce`).
//
// A local study runs its optimizer and workers on a private domain so that two studies on one machine
// never meet. Picking the id from the process id alone (150 + pid % 80) lets two concurrent runs collide
// once in 80; a collision puts two optimizers on one domain, and the second one exits. The lease makes the
// choice exclusive: it holds an flock(2) on a per-domain lock file for as long as it lives, and a run that
// finds a domain's file locked takes the next. The kernel drops the lock when the process dies (kill -9
// included), so a crashed run never leaves a domain taken.
#pragma once

#include <filesystem>
#include <string>

namespace cpgmatch::runtime {

class DomainLease {
 public:
  // The first free domain in [first, first + count), starting at first + (start_offset % count) and
  // wrapping. Lock files are lock_dir/cpgmatch-domain-<id>.lock; a file this user may not open (another
  // user's, made private) counts as taken. Throws std::runtime_error naming the file when a lock file can
  // neither be opened nor created or flock fails for another reason than "held", naming the range when all
  // `count` domains are leased; std::invalid_argument when count <= 0.
  static DomainLease acquire(int first, int count, int start_offset, const std::filesystem::path& lock_dir);

  // The host-wide lock directory, /tmp: every user's runs share loopback domains, so they share the lock
  // files too (not $TMPDIR or $XDG_RUNTIME_DIR, which can be per user).
  static std::filesystem::path default_lock_dir();

  DomainLease(DomainLease&& other) noexcept;
  DomainLease& operator=(DomainLease&& other) noexcept;
  DomainLease(const DomainLease&) = delete;
  DomainLease& operator=(const DomainLease&) = delete;
  ~DomainLease();

  int domain() const { return domain_; }

 private:
  DomainLease(int domain, int fd) : domain_(domain), fd_(fd) {}
  int domain_ = -1;
  int fd_ = -1;
};

}  // namespace cpgmatch::runtime

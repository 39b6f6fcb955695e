// Private DDS domains for local studies: two runs on one host never lease the same domain.
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "cpgmatch/runtime/domain_lease.hpp"

namespace cpgmatch::runtime {
namespace {

std::filesystem::path fresh_lock_dir(const std::string& name) {
  const auto dir = std::filesystem::path(::testing::TempDir()) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(DomainLease, TwoLeasesHeldAtOnceGetDifferentDomainsStartingAtTheOffset) {
  const auto dir = fresh_lock_dir("lease_two");
  const DomainLease first = DomainLease::acquire(150, 80, 7, dir);
  const DomainLease second = DomainLease::acquire(150, 80, 7, dir);  // same pid % 80: the old collision
  EXPECT_EQ(first.domain(), 157);
  EXPECT_EQ(second.domain(), 158);
  EXPECT_TRUE(std::filesystem::exists(dir / "cpgmatch-domain-157.lock"));
}

TEST(DomainLease, ADomainIsFreeAgainOnceItsLeaseIsGoneAndTheSearchWraps) {
  const auto dir = fresh_lock_dir("lease_wrap");
  std::optional<DomainLease> held = DomainLease::acquire(10, 3, 2, dir);
  EXPECT_EQ(held->domain(), 12);
  const DomainLease wrapped = DomainLease::acquire(10, 3, 2, dir);
  EXPECT_EQ(wrapped.domain(), 10);  // 12 taken, the range wraps to its start
  held.reset();
  EXPECT_EQ(DomainLease::acquire(10, 3, 2, dir).domain(), 12);
}

TEST(DomainLease, AllDomainsLeasedIsRefusedNamingTheRange) {
  const auto dir = fresh_lock_dir("lease_full");
  const DomainLease a = DomainLease::acquire(40, 2, 0, dir);
  const DomainLease b = DomainLease::acquire(40, 2, 0, dir);
  try {
    (void)DomainLease::acquire(40, 2, 0, dir);
    FAIL() << "expected a refusal";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("40-41"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--domain"), std::string::npos) << e.what();
  }
}

TEST(DomainLease, AnUnusableLockDirectoryIsNamed) {
  const auto missing = std::filesystem::path(::testing::TempDir()) / "no_such_dir" / "deeper";
  try {
    (void)DomainLease::acquire(150, 80, 0, missing);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_dir"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cpgmatch::runtime

// Fast DDS's shared-memory leftovers: segments whose lock file nobody holds belonged to a dead process and
// are removed; a held lock (a living owner) keeps its segment; unrelated files are never touched.
#include <fcntl.h>
#include <sys/file.h>

#include <fstream>

#include "cpgmatch/dds/shm_cleanup.hpp"

namespace {

void touch(const std::filesystem::path& p) { std::ofstream(p) << "x"; }

TEST(ShmCleanup, RemovesTheSegmentsAndPortsOfDeadProcessesOnly) {
  const auto dir = std::filesystem::temp_directory_path() / ("shm-cleanup-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  for (const char* f : {"fastrtps_0123456789abcdef", "fastrtps_0123456789abcdef_el",   // dead segment
                        "fastrtps_fedcba9876543210", "fastrtps_fedcba9876543210_el",   // live segment
                        "fastrtps_port7411", "fastrtps_port7411_el", "sem.fastrtps_port7411_mutex",  // dead port
                        "fastrtps_notasegment_el", "other_el", "fastrtps_0123456789abcdef.keep"}) {
    touch(dir / f);
  }
  // Lock files older than the start-up grace (5 s): a process that just made its lock file may not hold it yet.
  for (const auto& f : std::filesystem::directory_iterator(dir)) {
    std::filesystem::last_write_time(f.path(), std::filesystem::file_time_type::clock::now() - std::chrono::seconds(60));
  }
  touch(dir / "fastrtps_00000000000000ff");
  touch(dir / "fastrtps_00000000000000ff_el");  // unlocked but brand new: its owner may be starting
  // The living owner: an exclusive flock held on its lock file, as Fast DDS holds it.
  const int live = ::open((dir / "fastrtps_fedcba9876543210_el").c_str(), O_RDONLY);
  ASSERT_GE(live, 0);
  ASSERT_EQ(::flock(live, LOCK_EX | LOCK_NB), 0);
  const cpgmatch::dds::ShmCleanup c = cpgmatch::dds::remove_dead_shm_segments(dir);
  EXPECT_EQ(c.segments_removed, 1);
  EXPECT_EQ(c.ports_removed, 1);
  EXPECT_EQ(c.in_use, 1);
  for (const char* gone : {"fastrtps_0123456789abcdef", "fastrtps_0123456789abcdef_el", "fastrtps_port7411",
                           "fastrtps_port7411_el", "sem.fastrtps_port7411_mutex"}) {
    EXPECT_FALSE(std::filesystem::exists(dir / gone)) << gone;
  }
  for (const char* kept : {"fastrtps_fedcba9876543210", "fastrtps_fedcba9876543210_el", "fastrtps_notasegment_el",
                           "fastrtps_00000000000000ff_el",
                           "other_el", "fastrtps_0123456789abcdef.keep"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / kept)) << kept;
  }
  ::close(live);
  // A folder that does not exist is left alone, quietly.
  EXPECT_EQ(cpgmatch::dds::remove_dead_shm_segments(dir / "missing").segments_removed, 0);
  std::filesystem::remove_all(dir);
}

}  // namespace

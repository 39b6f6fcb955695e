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

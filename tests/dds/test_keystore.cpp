// DDS-Security fails closed: every file of an enclave that the security plugins read, crl.pem included, is
// required, and a missing, unreadable, corrupt or swapped one is an InputError naming it before any
// participant exists. Keystores from deploy/make-study-pki.sh (no DDS traffic here).
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "cpgmatch/dds/security.hpp"
#include "cpgmatch/errors.hpp"

namespace cpgmatch::dds {
namespace {

namespace fs = std::filesystem;

const fs::path kMakeStudyPki = fs::path(CPGMATCH_SOURCE_DIR) / "deploy" / "make-study-pki.sh";
constexpr const char* kFiles[] = {"identity_ca.cert.pem", "cert.pem",       "key.pem",        "crl.pem",
                                  "permissions_ca.cert.pem", "governance.p7s", "permissions.p7s"};

void make_keystore(const fs::path& dir, const std::string& enclaves = "") {
  const std::string command = kMakeStudyPki.string() + " " + dir.string() + " " + enclaves + " >/dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
}

std::string read(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Two keystores with their own CAs, made once per test process; each test breaks a copy of the first.
class Keystore : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("keystore-test-" + std::to_string(getpid()));
    fs::remove_all(root_);
    make_keystore(root_ / "made");
    make_keystore(root_ / "other");
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }
  void SetUp() override { fresh_copy(); }
  void TearDown() override { select_security({}); }

  void fresh_copy() {
    fs::remove_all(ks_);
    fs::copy(root_ / "made", ks_, fs::copy_options::recursive | fs::copy_options::copy_symlinks);
  }
  // The message of the InputError selecting `enclave` raises ("" when it is accepted).
  std::string refusal(const std::string& enclave = "worker") {
    try {
      select_security({ks_, enclave});
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
  fs::path file(const std::string& name, const std::string& enclave = "worker") const {
    return ks_ / "enclaves" / enclave / name;
  }
  void replace(const std::string& name, const fs::path& with) {
    fs::remove_all(file(name));
    fs::copy_file(with, file(name));
  }

  static inline fs::path root_;
  fs::path ks_ = root_ / "copy";
};

TEST_F(Keystore, EveryEnclaveMakeStudyPkiMakesIsAccepted) {
  for (const std::string enclave : {"optimizer", "worker", "operator", "viewer"}) {
    EXPECT_EQ(refusal(enclave), "") << enclave;
    EXPECT_EQ(selected_common_name(), enclave);
  }
}

TEST_F(Keystore, EveryFileIsRequiredAndAMissingOneIsNamed) {
  for (const char* name : kFiles) {
    fresh_copy();
    fs::remove(file(name));
    const std::string e = refusal();
    EXPECT_NE(e.find(file(name).string() + " is missing"), std::string::npos) << name << ": " << e;
  }
  // The revocation list above all: without it revocation was silently off. The message says how to make one.
  fresh_copy();
  fs::remove(file("crl.pem"));
  EXPECT_NE(refusal().find("make-study-pki.sh KEYSTORE revoke"), std::string::npos) << refusal();
}

TEST_F(Keystore, AnUnreadableFileIsNamed) {
  fs::remove(file("permissions.p7s"));
  fs::create_directory(file("permissions.p7s"));
  EXPECT_NE(refusal().find("permissions.p7s is not a regular file"), std::string::npos) << refusal();
  fresh_copy();
  std::ofstream(file("crl.pem"), std::ios::trunc).close();
  EXPECT_NE(refusal().find("crl.pem is empty"), std::string::npos) << refusal();
  if (geteuid() != 0) {  // root reads a file whatever its mode
    fresh_copy();
    fs::permissions(file("key.pem"), fs::perms::none);
    EXPECT_NE(refusal().find("key.pem cannot be read"), std::string::npos) << refusal();
  }
}

TEST_F(Keystore, ASwappedOrCorruptPermissionsFileIsNamed) {
  // The viewer's permissions in the worker's enclave: validly signed, but they grant CN=viewer.
  replace("permissions.p7s", file("permissions.p7s", "viewer"));
  std::string e = refusal();
  EXPECT_NE(e.find(file("permissions.p7s").string() + " grants 'CN=viewer' but not the subject"), std::string::npos)
      << e;
  // One byte changed in the signed text.
  fresh_copy();
  std::string text = read(file("permissions.p7s"));
  const std::size_t at = text.find("<subject_name>CN=worker");
  ASSERT_NE(at, std::string::npos);
  text[at + 17] = 'W';
  std::ofstream(file("permissions.p7s"), std::ios::binary | std::ios::trunc) << text;
  e = refusal();
  EXPECT_NE(e.find(file("permissions.p7s").string() + " is not signed by"), std::string::npos) << e;
  // Cut short.
  std::ofstream(file("permissions.p7s"), std::ios::binary | std::ios::trunc) << text.substr(0, 100);
  e = refusal();
  EXPECT_NE(e.find(file("permissions.p7s").string() + " is not an S/MIME signed document"), std::string::npos) << e;
  // The worker's permissions of another keystore (another CA).
  replace("permissions.p7s", root_ / "other" / "enclaves" / "worker" / "permissions.p7s");
  e = refusal();
  EXPECT_NE(e.find(file("permissions.p7s").string() + " is not signed by"), std::string::npos) << e;
}

TEST_F(Keystore, ASwappedCertificateKeyGovernanceOrRevocationListIsNamed) {
  const fs::path other = root_ / "other" / "enclaves" / "worker";
  const struct {
    const char* name;
    fs::path from;
    const char* says;
  } swaps[] = {
      {"key.pem", file("key.pem", "viewer"), "is not the key of"},
      {"cert.pem", other / "cert.pem", "is not signed by"},
      {"crl.pem", other / "crl.pem", "is not signed by"},
      {"governance.p7s", other / "governance.p7s", "is not signed by"},
      {"identity_ca.cert.pem", file("key.pem"), "is not a PEM certificate"},
  };
  for (const auto& swap : swaps) {
    fresh_copy();
    replace(swap.name, swap.from);
    const std::string e = refusal();
    EXPECT_NE(e.find(file(swap.name).string() + " " + swap.says), std::string::npos) << swap.name << ": " << e;
  }
}

TEST_F(Keystore, AKeystoreMadeBeforeRevocationGetsARevocationListInEveryEnclaveWhenExtended) {
  // What a keystore looked like before make-study-pki.sh knew CRLs: no crl.pem anywhere, no CRL settings.
  fs::remove(ks_ / "public" / "crl.pem");
  fs::remove(ks_ / "private" / "crlnumber");
  for (const std::string enclave : {"optimizer", "worker", "operator", "viewer"}) fs::remove(file("crl.pem", enclave));
  const std::string strip = "sed -i '/^crlnumber\\|^default_crl_days/d' " + (ks_ / "private" / "ca.cnf").string();
  ASSERT_EQ(std::system(strip.c_str()), 0);
  EXPECT_NE(refusal().find("crl.pem is missing"), std::string::npos);
  make_keystore(ks_, "node12:worker");  // adding an identity brings the CRL to the enclaves made before it
  for (const std::string enclave : {"optimizer", "worker", "operator", "viewer", "node12"}) {
    EXPECT_EQ(refusal(enclave), "") << enclave;
  }
}

}  // namespace
}  // namespace cpgmatch::dds

// The keystore of one local study (`cpgmatch study run`): a study CA and identities for its optimizer, its
// workers and its own client, made by deploy/make-study-pki.sh in a fresh 0700 folder and removed when the
// study ends. With it the local study runs under DDS-Security: authenticated, permissioned and encrypted,
// so another user of the machine can neither read nor steer it (loopback is shared by every local user).
// A SIGKILLed `study run` leaves the folder behind (0700, its keys worthless to anyone else: no process
// trusts that CA any more).
#pragma once

#include <filesystem>

namespace cpgmatch::cli {

class PrivateKeystore {
 public:
  // Makes the keystore; throws std::runtime_error naming the script and its output when it fails.
  PrivateKeystore();
  ~PrivateKeystore();
  PrivateKeystore(const PrivateKeystore&) = delete;
  PrivateKeystore& operator=(const PrivateKeystore&) = delete;

  const std::filesystem::path& path() const { return path_; }
  double make_time_s() const { return make_time_s_; }

 private:
  std::filesystem::path root_;  // the 0700 folder (mkdtemp), the keystore inside it
  std::filesystem::path path_;
  double make_time_s_ = 0.0;
};

}  // namespace cpgmatch::cli

#include "private_keystore.hpp"

#include <stdlib.h>

#include <chrono>
#include <fstream>
#include <iterator>
#include <thread>
#include <string>
#include <system_error>
#include <vector>

#include <fmt/format.h>

#include "child_process.hpp"
#include "cpgmatch/runtime/install_layout.hpp"

namespace cpgmatch::cli {

namespace fs = std::filesystem;

PrivateKeystore::PrivateKeystore() {
  std::string pattern = (fs::temp_directory_path() / "cpgmatch-study-keys-XXXXXX").string();
  std::vector<char> buffer(pattern.begin(), pattern.end());
  buffer.push_back('\0');
  if (::mkdtemp(buffer.data()) == nullptr) {  // created 0700: only this user can enter it
    throw std::runtime_error(fmt::format("cannot create a private keystore folder {}: {}", pattern,
                                         std::error_code(errno, std::generic_category()).message()));
  }
  root_ = buffer.data();
  path_ = root_ / "keystore";
  const fs::path script = runtime::pki_script();
  const auto start = std::chrono::steady_clock::now();
  // The default enclaves: optimizer, worker, operator (this client) and viewer, each with its role's
  // permissions; one day of validity is plenty for one study.
  const fs::path log = root_ / "make-study-pki.log";
  int status = -1;
  {
    ChildProcess pki({script.string(), path_.string(), "--days", "1"}, log.string());
    const auto deadline = start + std::chrono::seconds(60);
    while (pki.running() && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    status = pki.stop(0.0);
  }
  make_time_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (status != 0) {
    std::ifstream in(log);
    const std::string output((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::error_code ignored;
    fs::remove_all(root_, ignored);
    throw std::runtime_error(fmt::format("cannot make the study's private keystore with {} (exit {}):\n{}",
                                         script.string(), status, output));
  }
}

PrivateKeystore::~PrivateKeystore() {
  std::error_code ignored;
  fs::remove_all(root_, ignored);
}

}  // namespace cpgmatch::cli

// One optimizer per store: an exclusive advisory lock (flock) on "<store>.lock", held for the life of
// the service. Two optimizers on one store would issue colliding trial ids and each tell its optimizer
// only half of the reports. The kernel drops the lock when the process dies, SIGKILL included, so a
// crashed optimizer never blocks its successor.
#pragma once

#include <string>

namespace cpgmatch::study {

class StoreLock {
 public:
  // Throws InputError naming the store (and the holder's pid, when it wrote one) if it is locked.
  explicit StoreLock(const std::string& store_path);
  ~StoreLock();
  StoreLock(const StoreLock&) = delete;
  StoreLock& operator=(const StoreLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace cpgmatch::study

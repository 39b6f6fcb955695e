// One progress line per evaluation on stderr: count, current best, elapsed time and ETA.
#pragma once

#include <chrono>
#include <string>

namespace cpgmatch::cli {

class ProgressLine {
 public:
  ProgressLine(int total, bool quiet) : total_(total), quiet_(quiet), start_(std::chrono::steady_clock::now()) {}
  // `extra` is appended to the line (e.g. the last value or a failure note).
  void update(int done, double best, const std::string& extra = "") const;
  double elapsed_s() const;

 private:
  int total_;
  bool quiet_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace cpgmatch::cli

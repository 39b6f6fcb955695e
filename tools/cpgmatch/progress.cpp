#include "progress.hpp"

#include <fmt/format.h>

namespace cpgmatch::cli {

double ProgressLine::elapsed_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void ProgressLine::update(int done, double best, const std::string& extra) const {
  if (quiet_) return;
  const double elapsed = elapsed_s();
  const double eta = done > 0 ? elapsed / done * (total_ - done) : 0.0;
  fmt::print(stderr, "[{:>4}/{}] best {:<12.6g} elapsed {:6.1f}s  eta {:6.1f}s  {}\n", done, total_, best, elapsed,
             eta, extra);
}

}  // namespace cpgmatch::cli

// Optimizer flags shared by `optimize` and `bench-optimizer`.
#pragma once

#include <CLI/CLI.hpp>

#include "cpgmatch/bo/optimizer.hpp"

namespace cpgmatch::cli {

struct OptimizerFlags {
  int budget = 150;
  int initial = 15;
  std::string acquisition = "gp_hedge";
  std::string design = "random";
  std::string liar = "believer";
  std::string cost_transform = "none";
  std::uint64_t seed = 0;
  int batch = 1;
  bool quiet = false;
  bool json = false;

  void add_to(CLI::App* cmd);
  // Validates and converts; throws InputError naming the flag.
  bo::OptimizerOptions to_options() const;

 private:
  CLI::Option* initial_flag_ = nullptr;  // to tell an --initial given from the default
};

}  // namespace cpgmatch::cli

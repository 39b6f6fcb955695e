#include "optimizer_flags.hpp"

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "flag_checks.hpp"

namespace cpgmatch::cli {

void OptimizerFlags::add_to(CLI::App* cmd) {
  cmd->add_option("--budget", budget, "number of evaluations (default 150, as in the paper)");
  initial_flag_ = cmd->add_option("--initial", initial, "initial design points before the model is used (default 15)");
  cmd->add_option("--acq", acquisition, "gp_hedge | ei | pi | lcb");
  cmd->add_option("--design", design, "initial design: random | lhs | sobol | halton");
  cmd->add_option("--liar", liar, "fake result for pending points in batches: believer (the model's mean) | min | mean | max");
  cmd->add_option("--cost-transform", cost_transform, "what the GP models: none (the cost) | log (log cost; costs must be > 0)");
  cmd->add_option("--seed", seed, "random seed (same seed, same sequence)")->check(whole_non_negative());
  cmd->add_option("--batch", batch, "points proposed and evaluated in parallel");
  cmd->add_flag("--quiet", quiet, "no progress lines");
  cmd->add_flag("--json", json, "print one JSON object as the result");
}

bo::OptimizerOptions OptimizerFlags::to_options() const {
  if (budget < 1) throw InputError(fmt::format("--budget must be >= 1, got {}", budget));
  if (initial < 1) throw InputError(fmt::format("--initial must be >= 1, got {}", initial));
  if (batch < 1) throw InputError(fmt::format("--batch must be >= 1, got {}", batch));
  // More initial points than evaluations would leave the model unused, which is not what --initial asks
  // for. The default (15) is left alone with a smaller budget: every evaluation is then an initial point.
  if (initial_flag_ != nullptr && initial_flag_->count() > 0 && initial > budget) {
    throw InputError(fmt::format("--initial {} is more than --budget {}: at most as many initial points as "
                                 "evaluations",
                                 initial, budget));
  }
  bo::OptimizerOptions o;
  o.initial_points = initial;
  o.acquisition = bo::acquisition_from_string(acquisition);
  o.initial_design = bo::initial_design_from_string(design);
  o.liar = bo::liar_from_string(liar);
  o.cost_transform = bo::cost_transform_from_string(cost_transform);
  o.seed = seed;
  return o;
}

}  // namespace cpgmatch::cli

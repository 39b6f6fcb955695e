// Standard global-optimisation test functions in their usual domains, with their known minima.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "cpgmatch/bo/search_space.hpp"

namespace cpgmatch::bo {

struct TestFunction {
  std::string name;
  SearchSpace space;
  double global_minimum;
  std::function<double(const Eigen::VectorXd&)> f;
};

// branin, hartmann3, hartmann6, ackley (2-D), rosenbrock (2-D), levy (2-D), styblinski-tang (2-D),
// quadratic1d, ackley20 (20-D, box [-5, 10]), levy20 (20-D). Throws InputError listing the names for an unknown one.
TestFunction test_function(const std::string& name);
std::vector<std::string> test_function_names();

}  // namespace cpgmatch::bo

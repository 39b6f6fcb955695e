#include "cpgmatch/domain/candidate.hpp"

#include "cpgmatch/errors.hpp"
#include "cpgmatch/params.hpp"

namespace cpgmatch::domain {

std::optional<std::string> check_parameters(const std::map<std::string, double>& parameters) {
  if (parameters.empty()) return std::string("no parameters");
  CpgParameters p;
  for (const auto& [name, value] : parameters) {
    try {
      set_parameter(p, name, value, "candidate");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
  }
  return std::nullopt;
}

}  // namespace cpgmatch::domain

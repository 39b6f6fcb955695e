#include "cpgmatch/bo/model_state_json.hpp"

#include <stdexcept>
#include <vector>

namespace cpgmatch::bo {

namespace {

std::vector<double> to_vector(const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

Eigen::VectorXd to_eigen(const std::vector<double>& v) {
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

}  // namespace

nlohmann::json model_state_to_json(const ModelState& m) {
  nlohmann::json j = {{"observations", m.observations},
                      {"fits", m.fits},
                      {"have_hyperparameters", m.have_hyperparameters},
                      {"hyperparameters", to_vector(m.hyperparameters)},
                      {"hedge_gains", {m.hedge_gains[0], m.hedge_gains[1], m.hedge_gains[2]}}};
  if (m.have_fall_hyperparameters) j["fall_hyperparameters"] = to_vector(m.fall_hyperparameters);
  return j;
}

ModelState model_state_from_json(const nlohmann::json& j) {
  ModelState m;
  m.observations = j.at("observations").get<int>();
  m.fits = j.at("fits").get<int>();
  m.have_hyperparameters = j.at("have_hyperparameters").get<bool>();
  m.hyperparameters = to_eigen(j.at("hyperparameters").get<std::vector<double>>());
  const auto gains = j.at("hedge_gains").get<std::vector<double>>();
  if (gains.size() != 3) throw std::runtime_error("hedge_gains must hold 3 numbers");
  m.hedge_gains = Eigen::Vector3d(gains[0], gains[1], gains[2]);
  if (j.contains("fall_hyperparameters")) {  // absent: no fall seen yet, or a store from before the fall model
    m.have_fall_hyperparameters = true;
    m.fall_hyperparameters = to_eigen(j.at("fall_hyperparameters").get<std::vector<double>>());
  }
  return m;
}

}  // namespace cpgmatch::bo

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
  if (m.fitted_observations >= 0) j["fitted_observations"] = m.fitted_observations;
  if (m.optimised_observations >= 0) j["optimised_observations"] = m.optimised_observations;
  return j;
}

ModelState model_state_from_json(const nlohmann::json& j) {
  ModelState m;
  m.observations = j.at("observations").get<int>();
  m.fits = j.at("fits").get<int>();
  m.fitted_observations = j.value("fitted_observations", -1);  // absent in stores older than it
  m.optimised_observations = j.value("optimised_observations", -1);  // absent before the hyperparameter schedule
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

nlohmann::json hardware_model_state_to_json(const HardwareModelState& m) {
  nlohmann::json j = {{"simulation_observations", m.simulation_observations},
                      {"hardware_observations", m.hardware_observations},
                      {"fits", m.fits},
                      {"have_hyperparameters", m.have_hyperparameters},
                      {"hyperparameters", to_vector(m.hyperparameters)}};
  if (m.have_simulation_fall) j["simulation_fall_hyperparameters"] = to_vector(m.simulation_fall_hyperparameters);
  if (m.have_hardware_fall) j["hardware_fall_hyperparameters"] = to_vector(m.hardware_fall_hyperparameters);
  return j;
}

HardwareModelState hardware_model_state_from_json(const nlohmann::json& j) {
  HardwareModelState m;
  m.simulation_observations = j.at("simulation_observations").get<int>();
  m.hardware_observations = j.at("hardware_observations").get<int>();
  m.fits = j.at("fits").get<int>();
  m.have_hyperparameters = j.at("have_hyperparameters").get<bool>();
  m.hyperparameters = to_eigen(j.at("hyperparameters").get<std::vector<double>>());
  if (j.contains("simulation_fall_hyperparameters")) {  // absent: no simulated fall seen at the last fit
    m.have_simulation_fall = true;
    m.simulation_fall_hyperparameters = to_eigen(j.at("simulation_fall_hyperparameters").get<std::vector<double>>());
  }
  if (j.contains("hardware_fall_hyperparameters")) {
    m.have_hardware_fall = true;
    m.hardware_fall_hyperparameters = to_eigen(j.at("hardware_fall_hyperparameters").get<std::vector<double>>());
  }
  return m;
}

}  // namespace cpgmatch::bo

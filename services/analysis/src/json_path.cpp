#include "cpgmatch/analysis/json_path.hpp"

#include <algorithm>

namespace cpgmatch::analysis {
namespace {

void collect(const nlohmann::json& node, const std::string& prefix, std::map<std::string, double>& out) {
  if (node.is_number()) {
    out[prefix] = node.get<double>();
  } else if (node.is_boolean()) {
    out[prefix] = node.get<bool>() ? 1.0 : 0.0;
  } else if (node.is_object()) {
    for (const auto& [k, v] : node.items()) collect(v, prefix.empty() ? k : prefix + "." + k, out);
  } else if (node.is_array()) {
    for (std::size_t i = 0; i < node.size(); ++i) collect(node[i], prefix + "." + std::to_string(i), out);
  }
}

}  // namespace

nlohmann::json json_at(const nlohmann::json& root, const std::string& dotted_path) {
  const nlohmann::json* node = &root;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = dotted_path.find('.', start);
    const std::string key = dotted_path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (node->is_object() && node->contains(key)) {
      node = &(*node)[key];
    } else if (node->is_array() && !key.empty() && std::all_of(key.begin(), key.end(), ::isdigit) &&
               std::stoul(key) < node->size()) {
      node = &(*node)[std::stoul(key)];
    } else {
      return nullptr;
    }
    if (dot == std::string::npos) return *node;
    start = dot + 1;
  }
}

std::map<std::string, double> numeric_leaves(const nlohmann::json& root, const std::vector<std::string>& skip) {
  std::map<std::string, double> out;
  if (!root.is_object()) return out;
  for (const auto& [k, v] : root.items()) {
    if (std::find(skip.begin(), skip.end(), k) != skip.end()) continue;
    collect(v, k, out);
  }
  return out;
}

}  // namespace cpgmatch::analysis

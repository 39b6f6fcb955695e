#include "cpgmatch/yaml_reader.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch {

YamlReader YamlReader::from_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("{}: cannot open file", path));
  std::stringstream buffer;
  buffer << in.rdbuf();
  return from_string(buffer.str(), path);
}

YamlReader YamlReader::from_string(const std::string& text, const std::string& source_name) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}:{}: malformed YAML: {}", source_name, e.mark.line + 1, e.msg));
  }
  if (!root.IsMap()) {
    throw InputError(fmt::format("{}: expected a YAML mapping at the top level", source_name));
  }
  return YamlReader(root, source_name, "");
}

YamlReader::YamlReader(YAML::Node node, std::string source, std::string path)
    : node_(std::move(node)), source_(std::move(source)), path_(std::move(path)) {}

bool YamlReader::has(const std::string& key) const { return node_.IsMap() && node_[key].IsDefined(); }

std::string YamlReader::field(const std::string& key) const {
  if (key.empty()) return path_;
  return path_.empty() ? key : path_ + "." + key;
}

std::string YamlReader::where(const std::string& key) const {
  const YAML::Node n = (!key.empty() && has(key)) ? node_[key] : node_;
  const auto mark = n.Mark();
  if (mark.line < 0) return source_;
  return fmt::format("{}:{}", source_, mark.line + 1);
}

void YamlReader::fail(const std::string& key, const std::string& what) const {
  throw InputError(fmt::format("{}: field '{}': {}", where(key), field(key), what));
}

YamlReader YamlReader::child(const std::string& key) const {
  if (!has(key)) fail(key, "is missing");
  if (!node_[key].IsMap()) fail(key, "must be a mapping");
  return YamlReader(node_[key], source_, field(key));
}

double YamlReader::parse_double(const YAML::Node& value, const std::string& key) const {
  if (!value.IsScalar()) fail(key, "must be a number");
  const std::string text = value.Scalar();
  char* end = nullptr;
  const double parsed = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size()) fail(key, fmt::format("'{}' is not a number", text));
  if (!std::isfinite(parsed)) fail(key, fmt::format("must be finite, got '{}'", text));
  return parsed;
}

double YamlReader::get_double(const std::string& key, double fallback) const {
  return has(key) ? parse_double(node_[key], key) : fallback;
}

double YamlReader::require_double(const std::string& key) const {
  if (!has(key)) fail(key, "is missing");
  return parse_double(node_[key], key);
}

int YamlReader::get_int(const std::string& key, int fallback) const {
  if (!has(key)) return fallback;
  const double v = parse_double(node_[key], key);
  if (v != std::floor(v) || std::abs(v) > 2e9) fail(key, "must be a whole number");
  return static_cast<int>(v);
}

double YamlReader::get_double_in(const std::string& key, double fallback, double low, double high) const {
  const double v = get_double(key, fallback);
  if (v < low || v > high) fail(key, fmt::format("must be in [{}, {}], got {}", low, high, v));
  return v;
}

int YamlReader::get_int_in(const std::string& key, int fallback, int low, int high) const {
  const int v = get_int(key, fallback);
  if (v < low || v > high) fail(key, fmt::format("must be a whole number in [{}, {}], got {}", low, high, v));
  return v;
}

bool YamlReader::get_bool(const std::string& key, bool fallback) const {
  if (!has(key)) return fallback;
  const std::string text = node_[key].IsScalar() ? node_[key].Scalar() : "";
  if (text == "true" || text == "yes" || text == "on") return true;
  if (text == "false" || text == "no" || text == "off") return false;
  fail(key, fmt::format("must be true or false, got '{}'", text));
}

std::string YamlReader::get_string(const std::string& key, const std::string& fallback) const {
  if (!has(key)) return fallback;
  if (!node_[key].IsScalar()) fail(key, "must be a string");
  return node_[key].Scalar();
}

std::string YamlReader::require_string(const std::string& key) const {
  if (!has(key)) fail(key, "is missing");
  return get_string(key, "");
}

void YamlReader::check_keys() const {
  // yaml-cpp keeps the last of two equal keys and accepts a mapping or list as a key: both would let a
  // file mean something other than what it says, so both are refused with the line they are on.
  std::set<std::string> seen;
  for (const auto& entry : node_) {
    const auto mark = entry.first.Mark();
    const std::string at = mark.line < 0 ? source_ : fmt::format("{}:{}", source_, mark.line + 1);
    if (!entry.first.IsScalar()) {
      throw InputError(fmt::format("{}: field '{}': keys must be plain names, not a list or mapping", at, field("")));
    }
    if (!seen.insert(entry.first.Scalar()).second) {
      throw InputError(fmt::format("{}: field '{}': duplicate key (it appears twice in one mapping)", at,
                                   field(entry.first.Scalar())));
    }
  }
}

void YamlReader::reject_unknown_keys(const std::set<std::string>& known) const {
  check_keys();
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    if (!known.count(key)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      fail(key, fmt::format("unknown key (expected one of: {})", list));
    }
  }
}

void YamlReader::for_each_number(
    const std::function<void(const std::string&, double, const std::string&)>& fn) const {
  check_keys();
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    fn(key, parse_double(entry.second, key), where(key));
  }
}

}  // namespace cpgmatch

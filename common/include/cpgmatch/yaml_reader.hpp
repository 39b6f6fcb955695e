// Small helpers that read YAML with error messages naming the file, line and field.
//
// Every config loader in cpgmatch goes through YamlReader so that a bad value always produces
// "FILE:LINE: field 'a.b': <what is wrong>" and an InputError, never a yaml-cpp exception text.
#pragma once

#include <cstddef>
#include <functional>
#include <set>
#include <string>

#include <yaml-cpp/yaml.h>

namespace cpgmatch {

// The largest YAML text cpgmatch reads: 1 MiB. Every YAML file it has (study files, search spaces,
// parameter sets, the model and robot files) is a few kB; yaml-cpp's node tree takes about 70 times its
// text in memory, and a 12 MB study file of 700k keys held ~800 MB in the optimizer service for good.
// A larger text is refused before it is parsed.
inline constexpr std::size_t kMaxYamlBytes = std::size_t{1} << 20;

class YamlReader {
 public:
  // Parses a file (reading at most kMaxYamlBytes + 1 bytes of it); throws InputError with the file name
  // (and line for syntax errors).
  static YamlReader from_file(const std::string& path);
  // Parses text; `source_name` stands in for the file name in messages. The one door for every YAML text
  // in cpgmatch; it throws InputError naming source (and line) for a text over kMaxYamlBytes (before
  // parsing), a syntax error, a quoted string that is never closed, a second document (`---`, or anything
  // after `...`) and a top level that is not a mapping.
  static YamlReader from_string(const std::string& text, const std::string& source_name);

  YamlReader(YAML::Node node, std::string source, std::string path);

  bool has(const std::string& key) const;
  YamlReader child(const std::string& key) const;  // throws when missing or not a map

  double get_double(const std::string& key, double fallback) const;
  double require_double(const std::string& key) const;
  int get_int(const std::string& key, int fallback) const;
  bool get_bool(const std::string& key, bool fallback) const;
  std::string get_string(const std::string& key, const std::string& fallback) const;
  std::string require_string(const std::string& key) const;
  // A finite number in [low, high]; the message names the field, its file:line and the range.
  double get_double_in(const std::string& key, double fallback, double low, double high) const;
  int get_int_in(const std::string& key, int fallback, int low, int high) const;

  // Throws when the map has a key not in `known` (catches typos like "duty_factor_frnt"), a key twice,
  // or a key that is not a plain scalar.
  void reject_unknown_keys(const std::set<std::string>& known) const;
  // Throws for a duplicate or non-scalar key (reject_unknown_keys and for_each_number call it).
  void check_keys() const;

  // Calls fn(key, value-as-double, origin) for every entry of a map of numbers.
  void for_each_number(const std::function<void(const std::string&, double, const std::string&)>& fn) const;

  // "file:line" for this node, or for `key` inside it.
  std::string where(const std::string& key = "") const;
  std::string field(const std::string& key) const;  // dotted path of a key
  const YAML::Node& node() const { return node_; }
  const std::string& source() const { return source_; }

  [[noreturn]] void fail(const std::string& key, const std::string& what) const;

 private:
  double parse_double(const YAML::Node& value, const std::string& key) const;

  YAML::Node node_;
  std::string source_;
  std::string path_;
};

}  // namespace cpgmatch

#include "cpgmatch/study/model_file.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::study {

std::string with_model_file(const std::string& study_yaml, const std::string& study_path) {
  const YamlReader r = YamlReader::from_string(study_yaml, study_path);
  if (r.has(kModelFileTextKey)) r.fail(kModelFileTextKey, "is written by the submitting client; name the file in 'model' instead");
  if (!r.has("model") || !r.node()["model"].IsScalar()) return study_yaml;
  const std::string name = r.node()["model"].Scalar();
  if (r.node().Style() == YAML::EmitterStyle::Flow) {
    r.fail("model", "a model file needs the study written as a block mapping (one key per line)");
  }
  namespace fs = std::filesystem;
  const fs::path path = fs::path(name).is_absolute() ? fs::path(name) : fs::path(study_path).parent_path() / name;
  std::ifstream in(path);
  if (!in) r.fail("model", fmt::format("cannot read the model file '{}' ({}, relative to the study file)", name, path.string()));
  std::ostringstream text;
  text << in.rdbuf();
  if (text.str().size() > kMaxStudyFileBytes) {
    r.fail("model", fmt::format("the model file '{}' has {} bytes, more than {}", name, text.str().size(), kMaxStudyFileBytes));
  }
  // Appended, not re-emitted: the study's own lines keep their numbers for every later error. A JSON string
  // is a YAML double-quoted scalar.
  std::string quoted;
  try {
    quoted = nlohmann::json(text.str()).dump();
  } catch (const nlohmann::json::exception&) {
    r.fail("model", fmt::format("the model file '{}' is not UTF-8 text", name));
  }
  std::string out = study_yaml;
  if (!out.empty() && out.back() != '\n') out += '\n';
  out += fmt::format("# the content of {}, added by the submitting client\n{}: {}\n", name, kModelFileTextKey, quoted);
  return out;
}

}  // namespace cpgmatch::study

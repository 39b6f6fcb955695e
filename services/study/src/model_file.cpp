#include "cpgmatch/study/model_file.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/text.hpp"
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
  // A regular file only, its size checked before it is read (a FIFO hung, /dev/zero grew past 5 GB), and at
  // most kMaxStudyFileBytes: its content travels inside the study text, which may have no more.
  std::string content;
  try {
    content = read_text_file(path.string(), "model file", kMaxStudyFileBytes);
  } catch (const InputError& e) {
    r.fail("model", fmt::format("{} (relative to the study file: {})", e.what(), path.string()));
  }
  if (study_yaml.size() + content.size() > kMaxStudyFileBytes) {
    r.fail("model", fmt::format("the study file with its model file '{}' has {} bytes, more than a study may have ({})",
                                name, study_yaml.size() + content.size(), kMaxStudyFileBytes));
  }
  std::ostringstream text;
  text << content;
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

#include "gait_files.hpp"

#include <filesystem>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::cli {

domain::EnqueuedGait read_gait_file(const std::string& path, const std::string& shown_as) {
  const YamlReader file = YamlReader::from_file(path);
  const YamlReader map = file.has("params") ? file.child("params") : file;
  domain::EnqueuedGait gait;
  gait.source = shown_as;
  CpgParameters checked;
  // Only what the file gives: the service compares the values it does not search with the study's own, and a
  // compiled-in default standing in for a missing one could differ from them.
  map.for_each_number([&](const std::string& name, double value, const std::string& origin) {
    set_parameter(checked, name, value, origin);  // a known name, a finite value in its range
    gait.parameters[name] = value;
  });
  if (gait.parameters.empty()) throw InputError(fmt::format("{}: no parameter values in it", path));
  return gait;
}

std::vector<domain::EnqueuedGait> read_enqueued_gaits(const std::string& study_text, const std::string& study_path) {
  const study::StudyConfig config = study::load_study_config_text(study_text, study_path);
  if (config.enqueue_files.empty()) return {};
  const std::string where = YamlReader::from_string(study_text, study_path).where("enqueue");
  const std::filesystem::path folder = std::filesystem::path(study_path).parent_path();
  std::vector<domain::EnqueuedGait> gaits;
  for (const std::string& name : config.enqueue_files) {
    const std::filesystem::path file = std::filesystem::path(name).is_absolute() ? std::filesystem::path(name) : folder / name;
    try {
      gaits.push_back(read_gait_file(file.string(), name));
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: field 'enqueue': {}", where, e.what()));
    }
  }
  return gaits;
}

}  // namespace cpgmatch::cli

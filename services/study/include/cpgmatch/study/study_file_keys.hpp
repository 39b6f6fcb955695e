// The keys of a study file, with their values, defaults and meaning: the one list the parser checks a
// file against (study_config.cpp rejects a top-level key that is not here) and the manual is written
// from (cpgmatch-study(5), `cpgmatch --write-man-pages`). A key added to the parser without a line here is
// refused at submit, so the manual cannot fall behind.
#pragma once

#include <span>
#include <string>
#include <vector>

namespace cpgmatch::study {

struct StudyFileKey {
  const char* key;           // "budget"; a nested key as "hardware.strategy"
  const char* value;         // what the value is, e.g. "integer 1..100000"
  const char* default_text;  // "" when the key is required or has no default
  const char* description;   // one paragraph; units in SI
};

std::span<const StudyFileKey> study_file_keys();

// The top-level keys (those without a '.'), in the table's order.
std::vector<std::string> top_level_study_file_keys();

}  // namespace cpgmatch::study

// cpgmatch-study(5): the study file's keys, written from the table the parser checks files against
// (cpgmatch/study/study_file_keys.hpp).
#pragma once

#include <string>

#include "cpgmatch/runtime/man_pages.hpp"

namespace cpgmatch::cli {

runtime::ManPage study_file_man_page(const std::string& version);

}  // namespace cpgmatch::cli

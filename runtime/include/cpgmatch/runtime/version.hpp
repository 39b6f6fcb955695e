// The version every executable prints with --version: the project version and the git revision the
// binary was built from ("unknown" for a tarball that was not made by `git archive`).
#pragma once

#include <string>

namespace cpgmatch::runtime {

const char* project_version();
const char* git_revision();  // generated at build time (runtime/git_revision.cmake)

// "<program> <version> (git <revision>)"
std::string version_text(const std::string& program);

}  // namespace cpgmatch::runtime

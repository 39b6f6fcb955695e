// Where a cpgmatch executable finds the data shipped with it. An installed (or copied, or relocated)
// binary looks next to itself: <prefix>/bin/cpgmatch -> <prefix>/share/cpgmatch/{configs,fastdds}. A binary
// run from the build tree has no such folder and uses the source tree it was built from.
#pragma once

#include <filesystem>

namespace cpgmatch::runtime {

// The running executable's folder (/proc/self/exe, symlinks resolved).
std::filesystem::path executable_dir();

// $CPGMATCH_CONFIG_DIR when set, else <prefix>/share/cpgmatch/configs when it exists, else the source
// tree's configs/. Throws InputError when $CPGMATCH_CONFIG_DIR names no folder.
std::filesystem::path config_dir();

// <prefix>/share/cpgmatch/fastdds when it exists, else the source tree's deploy/fastdds/.
std::filesystem::path fastdds_profiles_dir();

// <prefix>/share/cpgmatch/make-study-pki.sh when installed, else the source tree's deploy/make-study-pki.sh:
// what `study run` makes its private keystore with.
std::filesystem::path pki_script();

// Puts config_dir() into $CPGMATCH_CONFIG_DIR, where the simulation's config loaders and every child
// process (rollout slots, the services `study run` starts) read it. Call once, first thing in main().
void export_config_dir();

}  // namespace cpgmatch::runtime

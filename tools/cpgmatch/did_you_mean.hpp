// "did you mean": when the command line did not parse, the word where a subcommand was expected and the
// nearest subcommand to it (typing distance), as git and cargo say it.
#pragma once

#include <optional>
#include <string>

#include <CLI/CLI.hpp>

namespace cpgmatch::cli {

// Edit distance with adjacent transpositions (optimal string alignment): "statsu" is 1 from "status".
std::size_t typing_distance(const std::string& a, const std::string& b);

// For a command line that failed to parse: "unknown command 'statsu'; did you mean 'cpgmatch status'?" when
// the first word after a command that has subcommands is none of them (with the commands there are when no
// name is near it). Empty when the failure was something else.
std::optional<std::string> unknown_command_hint(const CLI::App& app, int argc, const char* const* argv);

}  // namespace cpgmatch::cli

// Man pages written from the command-line definitions themselves, so a page never drifts from the code:
// one page per command and per subcommand (cpgmatch.1, cpgmatch-study.1, cpgmatch-study-run.1, ...), each
// with the synopsis, description, every visible option with its type, default and environment variable,
// the subcommands and SEE ALSO links.
//
// Every executable gets a hidden `--write-man-pages DIR` flag (add_man_page_flag); the build runs it
// (deploy/CMakeLists.txt) instead of help2man, which saw only the top-level --help and rendered "±" as "??".
// Text is written as roff with every non-ASCII character as a groff glyph escape (\[u00B1]), so pages
// render the same whatever the reader's locale.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace cpgmatch::runtime {

// Text as roff: backslashes escaped, a leading '.' or '\'' neutralised, '-' as \- (so options copy and
// search as hyphen-minus), non-ASCII UTF-8 as \[uXXXX].
std::string roff_escape(const std::string& text);

// The header line every page starts with: .TH NAME SECTION "" "VERSION" "cpgmatch manual".
std::string roff_title(const std::string& page_name, int section, const std::string& version);

struct ManPage {
  std::string file_name;  // e.g. cpgmatch-study-run.1
  std::string text;       // roff source
};

// The pages of `app` (the executable's root) and of all its visible subcommands, recursively.
// `program` is the executable's name; `version` goes in the page footer; `see_also` is appended to every
// page's SEE ALSO (e.g. "cpgmatch-study(5)").
std::vector<ManPage> man_pages_for(const CLI::App& app, const std::string& program, const std::string& version,
                                   const std::vector<std::string>& see_also = {});

// Writes pages into `dir` (created if missing); returns the paths written. Throws std::runtime_error
// naming the file when one cannot be written.
std::vector<std::filesystem::path> write_man_pages(const std::vector<ManPage>& pages,
                                                   const std::filesystem::path& dir);

// Adds the hidden `--write-man-pages DIR` flag: it writes the pages of `app` (and `extra_pages()`, e.g.
// a section-5 page of a file format) into DIR, then exits 0 without running any subcommand.
void add_man_page_flag(CLI::App& app, const std::string& program,
                       std::function<std::vector<ManPage>()> extra_pages = {},
                       std::vector<std::string> see_also = {});

}  // namespace cpgmatch::runtime

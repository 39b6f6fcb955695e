#include "cpgmatch/runtime/man_pages.hpp"

#include <fstream>
#include <iostream>
#include <stdexcept>

#include <fmt/format.h>

#include "cpgmatch/runtime/version.hpp"

namespace cpgmatch::runtime {
namespace {

// The code point of the UTF-8 sequence at text[i] and its length; a malformed byte stands for itself
// (U+FFFD would hide what the text really holds).
std::pair<char32_t, std::size_t> decode_utf8(const std::string& text, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char lead = byte(i);
  std::size_t length = lead >= 0xF0 ? 4 : lead >= 0xE0 ? 3 : lead >= 0xC0 ? 2 : 1;
  if (length == 1 || i + length > text.size()) return {lead, 1};
  char32_t code = lead & (0x3F >> (length - 1));
  for (std::size_t k = 1; k < length; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return {lead, 1};
    code = (code << 6) | (byte(i + k) & 0x3F);
  }
  return {code, length};
}

// CLI11 subcommands with an empty group are hidden from --help; they stay out of the manual too.
bool visible(const CLI::App* app) { return !app->get_group().empty(); }
bool visible(const CLI::Option* option) { return !option->get_group().empty(); }

// "cpgmatch study run" for the run subcommand of study.
std::string command_path(const CLI::App& app, const std::string& program) {
  if (app.get_parent() == nullptr) return program;
  return command_path(*app.get_parent(), program) + " " + app.get_name();
}

std::string page_name(const CLI::App& app, const std::string& program) {
  std::string path = command_path(app, program);
  for (char& c : path) {
    if (c == ' ') c = '-';
  }
  return path;
}

std::string option_names(const CLI::Option& option) {
  if (option.get_positional() && option.get_lnames().empty() && option.get_snames().empty()) {
    return "\\fI" + roff_escape(option.get_name(true)) + "\\fR";
  }
  std::string names;
  for (const auto& s : option.get_snames()) names += (names.empty() ? "" : ", ") + std::string("\\fB\\-") + roff_escape(s) + "\\fR";
  for (const auto& l : option.get_lnames()) {
    names += (names.empty() ? "" : ", ") + std::string("\\fB\\-\\-") + roff_escape(l) + "\\fR";
  }
  // A flag takes no value; an option shows the kind of value it takes.
  if (option.get_type_size() != 0 && !option.get_type_name().empty()) {
    names += " \\fI" + roff_escape(option.get_type_name()) + "\\fR";
  }
  return names;
}

std::string options_section(const CLI::App& app) {
  std::string out;
  for (const CLI::Option* option : app.get_options([](const CLI::Option* o) { return visible(o); })) {
    out += ".TP\n" + option_names(*option) + "\n";
    std::string text = option->get_description();
    std::vector<std::string> notes;
    if (option->get_required()) notes.emplace_back("required");
    if (!option->get_default_str().empty()) notes.push_back("default: " + option->get_default_str());
    if (!option->get_envname().empty()) notes.push_back("environment: " + option->get_envname());
    if (!notes.empty()) text += (text.empty() ? "" : " ") + std::string("(") + fmt::format("{}", fmt::join(notes, "; ")) + ")";
    out += roff_escape(text.empty() ? "(no description)" : text) + "\n";
  }
  return out;
}

std::string synopsis(const CLI::App& app, const std::string& program) {
  std::string out = ".B " + roff_escape(command_path(app, program)) + "\n";
  if (!app.get_options([](const CLI::Option* o) { return visible(o) && !o->get_positional(); }).empty()) {
    out += "[\\fIOPTIONS\\fR]\n";
  }
  for (const CLI::Option* option : app.get_options([](const CLI::Option* o) { return o->get_positional(); })) {
    const std::string name = "\\fI" + roff_escape(option->get_name(true)) + "\\fR";
    out += (option->get_required() ? name : "[" + name + "]") + "\n";
  }
  if (!app.get_subcommands([](const CLI::App* s) { return visible(s); }).empty()) out += "\\fISUBCOMMAND\\fR ...\n";
  return out;
}

// The description of a command, paragraph by paragraph (a blank line in the text starts a new one).
std::string paragraphs(const std::string& text) {
  std::string out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = text.find("\n\n", start);
    const std::string part = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!part.empty()) out += ".PP\n" + roff_escape(part) + "\n";
    if (end == std::string::npos) break;
    start = end + 2;
  }
  return out;
}

ManPage page_for(const CLI::App& app, const std::string& program, const std::string& version,
                 const std::vector<std::string>& see_also) {
  const std::string name = page_name(app, program);
  std::string text = roff_title(name, 1, version);
  std::string summary = app.get_description();
  if (summary.empty()) summary = command_path(app, program);
  text += ".SH NAME\n" + roff_escape(name) + " \\- " + roff_escape(summary.substr(0, summary.find('\n'))) + "\n";
  text += ".SH SYNOPSIS\n" + synopsis(app, program);
  text += ".SH DESCRIPTION\n" + paragraphs(app.get_description());
  if (!app.get_footer().empty()) text += paragraphs(app.get_footer());
  text += ".SH OPTIONS\n" + options_section(app);

  const auto subcommands = app.get_subcommands([](const CLI::App* s) { return visible(s); });
  std::vector<std::string> links;
  if (!subcommands.empty()) {
    text += ".SH SUBCOMMANDS\n";
    for (const CLI::App* sub : subcommands) {
      text += ".TP\n\\fB" + roff_escape(sub->get_name()) + "\\fR\n" +
              roff_escape(sub->get_description().substr(0, sub->get_description().find('\n'))) +
              " (see \\fB" + roff_escape(page_name(*sub, program)) + "\\fR(1))\n";
      links.push_back(page_name(*sub, program) + "(1)");
    }
  }
  if (app.get_parent() != nullptr) links.insert(links.begin(), page_name(*app.get_parent(), program) + "(1)");
  links.insert(links.end(), see_also.begin(), see_also.end());
  if (!links.empty()) {
    text += ".SH SEE ALSO\n";
    for (std::size_t i = 0; i < links.size(); ++i) {
      const auto open = links[i].find('(');
      text += ".BR " + roff_escape(links[i].substr(0, open)) + " " + links[i].substr(open) +
              (i + 1 < links.size() ? ",\n" : "\n");
    }
  }
  return ManPage{name + ".1", text};
}

void collect_pages(const CLI::App& app, const std::string& program, const std::string& version,
                   const std::vector<std::string>& see_also, std::vector<ManPage>& pages) {
  pages.push_back(page_for(app, program, version, see_also));
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App* s) { return visible(s); })) {
    collect_pages(*sub, program, version, see_also, pages);
  }
}

}  // namespace

std::string roff_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  bool line_start = true;
  for (std::size_t i = 0; i < text.size();) {
    const char c = text[i];
    if (static_cast<unsigned char>(c) >= 0x80) {
      const auto [code, length] = decode_utf8(text, i);
      out += fmt::format("\\[u{:04X}]", static_cast<std::uint32_t>(code));
      i += length;
      line_start = false;
      continue;
    }
    if (line_start && (c == '.' || c == '\'')) out += "\\&";
    if (c == '\\') {
      out += "\\e";
    } else if (c == '-') {
      out += "\\-";
    } else {
      out += c;
    }
    line_start = c == '\n';
    ++i;
  }
  return out;
}

std::string roff_title(const std::string& page_name, int section, const std::string& version) {
  std::string upper = page_name;
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return fmt::format(".TH \"{}\" {} \"\" \"{}\" \"cpgmatch manual\"\n", roff_escape(upper), section,
                     roff_escape(version));
}

std::vector<ManPage> man_pages_for(const CLI::App& app, const std::string& program, const std::string& version,
                                   const std::vector<std::string>& see_also) {
  std::vector<ManPage> pages;
  collect_pages(app, program, version, see_also, pages);
  return pages;
}

std::vector<std::filesystem::path> write_man_pages(const std::vector<ManPage>& pages,
                                                   const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  std::vector<std::filesystem::path> written;
  for (const ManPage& page : pages) {
    const auto path = dir / page.file_name;
    std::ofstream out(path, std::ios::binary);
    out << page.text;
    if (!out.flush()) throw std::runtime_error(fmt::format("{}: cannot write the man page", path.string()));
    written.push_back(path);
  }
  return written;
}

void add_man_page_flag(CLI::App& app, const std::string& program, std::function<std::vector<ManPage>()> extra_pages,
                       std::vector<std::string> see_also) {
  // Hidden (empty group): it is for the build, not for users. Triggered while parsing, so it works
  // without the subcommand the root otherwise requires.
  app.add_option_function<std::string>(
         "--write-man-pages",
         [&app, program, extra_pages, see_also](const std::string& dir) {
           auto pages = man_pages_for(app, program, version_text(program), see_also);
           if (extra_pages) {
             for (auto& page : extra_pages()) pages.push_back(std::move(page));
           }
           write_man_pages(pages, dir);
           std::cout << fmt::format("{}: {} man pages written to {}", program, pages.size(), dir) << std::endl;
           throw CLI::Success();
         },
         "write the man pages into DIR and exit")
      ->group("")
      ->trigger_on_parse();
}

}  // namespace cpgmatch::runtime

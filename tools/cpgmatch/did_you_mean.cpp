#include "did_you_mean.hpp"

#include <algorithm>
#include <vector>

#include <fmt/format.h>

namespace cpgmatch::cli {

std::size_t typing_distance(const std::string& a, const std::string& b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[n][m];
}

std::optional<std::string> unknown_command_hint(const CLI::App& app, int argc, const char* const* argv) {
  const CLI::App* current = &app;
  std::string path = "cpgmatch";  // CLI11 names the app after argv[0], a path: users type the command
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.empty() || word[0] == '-') return std::nullopt;  // options: the failure is theirs to explain
    const auto subcommands = current->get_subcommands([](const CLI::App*) { return true; });
    if (subcommands.empty()) return std::nullopt;
    const auto named = std::find_if(subcommands.begin(), subcommands.end(),
                                    [&](const CLI::App* s) { return s->get_name() == word; });
    if (named != subcommands.end()) {
      current = *named;
      path += " " + word;
      continue;
    }
    // The nearest name within a third of the word's length (at least one edit), so that a short typo is
    // caught and an unrelated word is not "corrected".
    std::string best;
    std::size_t best_distance = std::max<std::size_t>(1, word.size() / 3) + 1;
    std::vector<std::string> names;
    for (const CLI::App* s : subcommands) {
      if (s->get_group().empty()) continue;  // hidden (internal) commands are neither listed nor suggested
      names.push_back(s->get_name());
      const std::size_t distance = typing_distance(word, s->get_name());
      if (distance < best_distance) {
        best_distance = distance;
        best = s->get_name();
      }
    }
    if (!best.empty()) return fmt::format("unknown command '{}'; did you mean '{} {}'?", word, path, best);
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    return fmt::format("unknown command '{}' for '{}'; its commands are: {}", word, path, list);
  }
  return std::nullopt;
}

}  // namespace cpgmatch::cli

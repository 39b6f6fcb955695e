// Checks on text that crosses the program's boundary (study names, ids): valid UTF-8, printable, bounded.
// A name that is not UTF-8 would be stored, then break every JSON reader of the study state.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace cpgmatch {

// True for well-formed UTF-8 (no overlong forms, no surrogates, nothing above U+10FFFF).
bool is_valid_utf8(std::string_view text);

// Why `name` is not acceptable as a name of at most `max_bytes` bytes (empty, too long, not UTF-8, or
// holding control characters), or nothing when it is.
std::optional<std::string> name_problem(std::string_view name, std::size_t max_bytes);

// A whole text file of at most `max_bytes`; InputError "<what>: ..." when it cannot be opened, is not a
// regular file (a FIFO would block for ever, /dev/zero read without end: refused before reading), or is
// larger (checked on its size before reading, and again while reading, so a file that grows is bounded too).
// `what`: the flag or field that named it, or the path again. Default bound: kMaxYamlBytes (1 MiB).
std::string read_text_file(const std::string& path, const std::string& what, std::size_t max_bytes = std::size_t{1} << 20);

// `text` as it may be echoed in a message: control characters, invalid UTF-8 bytes and the characters that
// reorder or hide text (bidi overrides and isolates, zero-width and line separators, BOM) shown as escapes
// (\n, \x1b, \xff for a bad byte, \u202e), and cut to `max_bytes` with "..." after. A name or value from a
// file or the wire can then not rewrite the terminal, reverse what follows it or hide in plain sight.
std::string escape_for_message(std::string_view text, std::size_t max_bytes = 200);

// A whole message as printed by an executable ("error: ..."): each of its lines through escape_for_message
// (lines kept, up to 64 KiB each). The one door every echoed input passes on its way to a terminal.
std::string escape_message_lines(std::string_view message);

}  // namespace cpgmatch

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

// A whole text file; InputError "<what>: cannot read '<path>'" when it cannot be opened (what: the flag or
// field that named it, or the path again).
std::string read_text_file(const std::string& path, const std::string& what);

// A whole regular file of at most `max_bytes`: a special file (/dev/zero, a pipe), a folder or a larger
// file is an InputError naming `what` before anything is read.
std::string read_regular_text_file(const std::string& path, const std::string& what, std::size_t max_bytes);

// `text` as it may be echoed in a message: control characters, bytes that are not UTF-8 and the Unicode
// bidirectional controls (U+202A..U+202E, U+2066..U+2069, which reorder what a terminal shows) are written
// as escapes (\n, \x9f, \u202e), so that input can never forge or hide part of the message.
std::string escape_for_message(std::string_view text);

}  // namespace cpgmatch

#include "cpgmatch/yaml_reader.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/eventhandler.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch {

namespace {

std::string limit_text() { return fmt::format("1 MiB ({} bytes)", kMaxYamlBytes); }

// A line that is a document marker: "---" or "..." at column 0, alone or followed by a blank.
bool is_marker(std::string_view line, std::string_view marker) {
  return line.substr(0, 3) == marker && (line.size() == 3 || line[3] == ' ' || line[3] == '\t' || line[3] == '\r');
}

// A line that carries content: not blank, not only a comment, not a directive ("%YAML 1.2").
bool has_content(std::string_view line) {
  const std::size_t first = line.find_first_not_of(" \t\r");
  return first != std::string_view::npos && line[first] != '#' && !(first == 0 && line[0] == '%');
}

// The 0-based line where a second document begins: a "---" after content or after "...", or content after
// "...". Only called once yaml-cpp has found two documents; -1 if the lines do not show where.
int second_document_line(const std::string& text) {
  bool content = false, ended = false;
  std::size_t start = 0;
  for (int line = 0; start < text.size(); ++line) {
    const std::size_t end = std::min(text.find('\n', start), text.size());
    const std::string_view l(text.data() + start, end - start);
    start = end + 1;
    if (is_marker(l, "---")) {
      if (content || ended) return line;
      content = has_content(l.substr(3));  // "--- {a: 1}" starts a document with content on its line
    } else if (is_marker(l, "...")) {
      ended = true;
    } else if (has_content(l)) {
      if (ended) return line;
      content = true;
    }
  }
  return -1;
}

// The text with an explicit document end ("...") on a line of its own appended. yaml-cpp 0.7 accepts a
// quoted string that is never closed when the text ends with a line break (its scanner leaves the scalar
// at the end of the input without the "illegal EOF in scalar" it raises mid-line), taking the rest of the
// file as the string. A document end cannot be inside a quoted string, so with it yaml-cpp always stops
// there with "illegal document indicator in scalar". The marker ends a document without adding anything
// to it: a file that already ends with "..." reads the same.
std::string with_document_end(const std::string& text) {
  return text + (text.empty() || text.back() == '\n' ? "" : "\n") + "...\n";
}

// Remembers where the last quoted scalar began: yaml-cpp tags a quoted (or block) scalar "!", a plain one "?".
class LastQuotedScalar : public YAML::EventHandler {
 public:
  YAML::Mark mark = YAML::Mark::null_mark();
  void OnScalar(const YAML::Mark& at, const std::string& tag, YAML::anchor_t, const std::string&) override {
    if (tag == "!") mark = at;
  }
  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

// Where the quoted string that runs into line `error_line` (0-based) opens. yaml-cpp only says where it met
// a document marker; the text up to that line, parsed without the marker, hands over the open string as its
// last quoted scalar (the very leniency described above, put to use on the error path only) before any
// error of what encloses it (an unclosed flow mapping). -1 if it cannot tell.
int unterminated_quote_line(const std::string& text, int error_line) {
  std::size_t cut = 0;
  for (int line = 0; line < error_line && cut < text.size(); ++line) {
    cut = std::min(text.find('\n', cut), text.size() - 1) + 1;
  }
  std::istringstream prefix(text.substr(0, cut) + (cut > 0 && text[cut - 1] == '\n' ? "" : "\n"));
  LastQuotedScalar last;
  try {
    YAML::Parser parser(prefix);
    while (parser.HandleNextDocument(last)) {
    }
  } catch (const YAML::Exception&) {
    // expected when the open string sits inside a flow collection: what was seen before counts
  }
  return last.mark.line;
}

// The number of lines of `text` (a last line without a line break counts).
int line_count(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n')) + (text.empty() || text.back() == '\n' ? 0 : 1);
}

// The InputError for a yaml-cpp parse error of `text`. An error yaml-cpp finds at the appended "..." is at
// the end of the text: its last line is named, never a line the file does not have.
InputError parse_error(const std::string& text, const std::string& source, const YAML::Exception& e) {
  const auto at = [&](int line) {
    return fmt::format("{}:{}", source, std::clamp(line + 1, 1, std::max(1, line_count(text))));
  };
  if (e.msg == YAML::ErrorMsg::DOC_IN_SCALAR) {
    const int open = unterminated_quote_line(text, e.mark.line);
    return InputError(fmt::format("{}: malformed YAML: a quoted string opened on this line is never closed",
                                  at(open >= 0 ? open : e.mark.line)));
  }
  return InputError(fmt::format("{}: malformed YAML: {}", at(e.mark.line), e.msg));
}

}  // namespace

YamlReader YamlReader::from_file(const std::string& path) {
  // A FIFO would block the open or the read for ever, a device read without end: files only.
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    throw InputError(fmt::format("{}: not a regular file; only files are read", path));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot open file", path));
  // One byte past the limit is enough to refuse a larger file without reading it all.
  std::string text(kMaxYamlBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (in.bad()) throw InputError(fmt::format("{}: cannot read file", path));
  text.resize(static_cast<std::size_t>(in.gcount()));
  if (text.size() > kMaxYamlBytes) {
    throw InputError(fmt::format("{}: larger than {}, the most cpgmatch reads from a YAML text; not parsed", path,
                                 limit_text()));
  }
  return from_string(text, path);
}

YamlReader YamlReader::from_string(const std::string& text, const std::string& source_name) {
  if (text.size() > kMaxYamlBytes) {
    throw InputError(fmt::format("{}: larger than {}, the most cpgmatch reads from a YAML text ({} bytes); not parsed",
                                 source_name, limit_text(), text.size()));
  }
  std::vector<YAML::Node> documents;
  try {
    documents = YAML::LoadAll(with_document_end(text));
  } catch (const YAML::Exception& e) {
    throw parse_error(text, source_name, e);
  }
  if (documents.size() > 1) {
    // yaml-cpp's Load() would keep the first document and drop the rest without a word.
    const int line = second_document_line(text);
    throw InputError(fmt::format("{}: a second YAML document ('---', or content after '...'); a cpgmatch YAML "
                                 "text holds one document",
                                 line >= 0 ? fmt::format("{}:{}", source_name, line + 1) : source_name));
  }
  const YAML::Node root = documents.empty() ? YAML::Node() : documents.front();
  if (!root.IsMap()) {
    throw InputError(fmt::format("{}: expected a YAML mapping at the top level", source_name));
  }
  return YamlReader(root, source_name, "");
}

YamlReader::YamlReader(YAML::Node node, std::string source, std::string path)
    : node_(std::move(node)), source_(std::move(source)), path_(std::move(path)) {}

bool YamlReader::has(const std::string& key) const { return node_.IsMap() && node_[key].IsDefined(); }

std::string YamlReader::field(const std::string& key) const {
  if (key.empty()) return path_;
  return path_.empty() ? key : path_ + "." + key;
}

std::string YamlReader::where(const std::string& key) const {
  const YAML::Node n = (!key.empty() && has(key)) ? node_[key] : node_;
  const auto mark = n.Mark();
  if (mark.line < 0) return source_;
  return fmt::format("{}:{}", source_, mark.line + 1);
}

void YamlReader::fail(const std::string& key, const std::string& what) const {
  throw InputError(fmt::format("{}: field '{}': {}", where(key), field(key), what));
}

YamlReader YamlReader::child(const std::string& key) const {
  if (!has(key)) fail(key, "is missing");
  if (!node_[key].IsMap()) fail(key, "must be a mapping");
  return YamlReader(node_[key], source_, field(key));
}

double YamlReader::parse_double(const YAML::Node& value, const std::string& key) const {
  if (!value.IsScalar()) fail(key, "must be a number");
  const std::string text = value.Scalar();
  char* end = nullptr;
  const double parsed = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size()) fail(key, fmt::format("'{}' is not a number", text));
  if (!std::isfinite(parsed)) fail(key, fmt::format("must be finite, got '{}'", text));
  return parsed;
}

double YamlReader::get_double(const std::string& key, double fallback) const {
  return has(key) ? parse_double(node_[key], key) : fallback;
}

double YamlReader::require_double(const std::string& key) const {
  if (!has(key)) fail(key, "is missing");
  return parse_double(node_[key], key);
}

int YamlReader::get_int(const std::string& key, int fallback) const {
  if (!has(key)) return fallback;
  const double v = parse_double(node_[key], key);
  if (v != std::floor(v) || std::abs(v) > 2e9) fail(key, "must be a whole number");
  return static_cast<int>(v);
}

double YamlReader::get_double_in(const std::string& key, double fallback, double low, double high) const {
  const double v = get_double(key, fallback);
  if (v < low || v > high) fail(key, fmt::format("must be in [{}, {}], got {}", low, high, v));
  return v;
}

int YamlReader::get_int_in(const std::string& key, int fallback, int low, int high) const {
  const int v = get_int(key, fallback);
  if (v < low || v > high) fail(key, fmt::format("must be a whole number in [{}, {}], got {}", low, high, v));
  return v;
}

bool YamlReader::get_bool(const std::string& key, bool fallback) const {
  if (!has(key)) return fallback;
  const std::string text = node_[key].IsScalar() ? node_[key].Scalar() : "";
  if (text == "true" || text == "yes" || text == "on") return true;
  if (text == "false" || text == "no" || text == "off") return false;
  fail(key, fmt::format("must be true or false, got '{}'", text));
}

std::string YamlReader::get_string(const std::string& key, const std::string& fallback) const {
  if (!has(key)) return fallback;
  if (!node_[key].IsScalar()) fail(key, "must be a string");
  return node_[key].Scalar();
}

std::string YamlReader::require_string(const std::string& key) const {
  if (!has(key)) fail(key, "is missing");
  return get_string(key, "");
}

void YamlReader::check_keys() const {
  // yaml-cpp keeps the last of two equal keys and accepts a mapping or list as a key: both would let a
  // file mean something other than what it says, so both are refused with the line they are on.
  std::set<std::string> seen;
  for (const auto& entry : node_) {
    const auto mark = entry.first.Mark();
    const std::string at = mark.line < 0 ? source_ : fmt::format("{}:{}", source_, mark.line + 1);
    if (!entry.first.IsScalar()) {
      throw InputError(fmt::format("{}: field '{}': keys must be plain names, not a list or mapping", at, field("")));
    }
    if (!seen.insert(entry.first.Scalar()).second) {
      throw InputError(fmt::format("{}: field '{}': duplicate key (it appears twice in one mapping)", at,
                                   field(entry.first.Scalar())));
    }
  }
}

void YamlReader::reject_unknown_keys(const std::set<std::string>& known) const {
  check_keys();
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    if (!known.count(key)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      fail(key, fmt::format("unknown key (expected one of: {})", list));
    }
  }
}

void YamlReader::for_each_number(
    const std::function<void(const std::string&, double, const std::string&)>& fn) const {
  check_keys();
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    fn(key, parse_double(entry.second, key), where(key));
  }
}

}  // namespace cpgmatch

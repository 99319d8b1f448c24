#pragma once
/// @file
/// Visitors over the key lists of the config structs (each struct's static `visit(self, v)`, see
/// mlmap/core/config.h): reading YAML (YamlReader), writing it (YamlWriter), the commented
/// default file (CommentedYamlWriter) and the Markdown key reference (MarkdownKeyTable). Every
/// key name, unit and meaning therefore lives in one place, next to the struct.
///
/// Value types: double, int, std::uint32_t, bool, std::string, std::optional<bool> (null: unset),
/// fixed-size Eigen vectors (YAML lists `[x, y, z]`) and UnknownAs (its name).

#include "mlmap/config/yaml_section.h"
#include "mlmap/core/config.h"

#include <yaml-cpp/yaml.h>

#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace mlmap::config {

/// `name` under the dotted `parent` path ("" is the document's top level).
inline std::string childPath(const std::string& parent, const std::string& name) {
  return parent.empty() ? name : parent + "." + name;
}

/// Reads the keys of a config struct from a Section: a missing key keeps the field's value, a bad
/// one is an error in section.errors() naming "path.key", and a nested struct is read from the
/// nested mapping of the same name (its unknown keys are reported when that mapping is done).
class YamlReader {
 public:
  /// Reads from `section`, which must outlive this reader.
  explicit YamlReader(Section& section) : section_(section) {}

  /// Reads key `name` into `field` (see the file comment for the types).
  template <class T>
  void key(const char* name, T& field, const char* /*unit*/, const char* /*doc*/) {
    read(name, &field);
  }

  /// Reads the nested mapping `name` into `sub` with its own key list.
  template <class S>
  void section(const char* name, S& sub, const char* /*doc*/) {
    std::vector<std::string>* errors = section_.errors();
    const std::size_t before = errors->size();
    {
      Section child(section_.child(name), childPath(section_.path(), name), errors);
      YamlReader reader(child);
      visitConfig(sub, reader);
    }  // reports the nested mapping's unknown keys
    problems_[&sub] = errors->size() - before;
  }

  /// Problems found while reading the section that filled `sub` (0 when none or not read).
  [[nodiscard]] std::size_t problemsIn(const void* sub) const {
    const auto it = problems_.find(sub);
    return it == problems_.end() ? 0 : it->second;
  }

 private:
  template <class T>
  void read(const char* name, T* field) {
    section_.read(name, field);
  }
  template <class Scalar, int kRows>
  void read(const char* name, Eigen::Matrix<Scalar, kRows, 1>* field) {
    section_.readVector(name, field);
  }
  void read(const char* name, UnknownAs* field) {
    std::string text = toString(*field);
    section_.read(name, &text);
    if (!parseUnknownAs(text, field)) {
      section_.errors()->push_back(childPath(section_.path(), name) + ": must be " +
                                   unknownAsChoices() + " (got " + text + ")");
    }
  }
  /// Absent or null (`key:`): unset, whatever the environment decides.
  void read(const char* name, std::optional<bool>* field) {
    const YAML::Node node = section_.child(name);
    if (!node || node.IsNull()) return;
    bool value = false;
    std::vector<std::string>* errors = section_.errors();
    const std::size_t before = errors->size();
    section_.read(name, &value);
    // cppcheck-suppress knownConditionTrueFalse ; section_.read appends to *errors on a bad value
    if (errors->size() == before) *field = value;
  }

  Section& section_;
  std::map<const void*, std::size_t> problems_;
};

/// Writes the keys of a config struct into an open YAML mapping of `out`, every key present;
/// text double-quoted, so that any text reads back as itself.
class YamlWriter {
 public:
  /// Writes into `out`, which must outlive this writer.
  explicit YamlWriter(YAML::Emitter& out) : out_(out) {}

  /// Writes `name: value`.
  template <class T>
  void key(const char* name, const T& field, const char* /*unit*/, const char* /*doc*/) {
    out_ << YAML::Key << name << YAML::Value;
    write(field);
  }
  /// Writes `name:` and the nested mapping of `sub`.
  template <class S>
  void section(const char* name, const S& sub, const char* /*doc*/) {
    out_ << YAML::Key << name << YAML::Value << YAML::BeginMap;
    visitConfig(sub, *this);
    out_ << YAML::EndMap;
  }

 private:
  template <class T>
  void write(const T& value) {
    out_ << value;
  }
  template <class Scalar, int kRows>
  void write(const Eigen::Matrix<Scalar, kRows, 1>& value) {
    out_ << YAML::Flow << YAML::BeginSeq;
    for (int i = 0; i < kRows; ++i) out_ << value[i];
    out_ << YAML::EndSeq;
  }
  void write(const std::string& value) { out_ << YAML::DoubleQuoted << value; }
  void write(UnknownAs value) { out_ << toString(value); }
  void write(const std::optional<bool>& value) {
    if (value) {
      out_ << *value;
    } else {
      out_ << YAML::Null;  // the environment decides
    }
  }

  YAML::Emitter& out_;
};

/// How a default value is written in the commented default files and the key reference: numbers
/// as typed (a double always with a '.', 10.0), text plain when YAML reads it back as the same
/// text and double-quoted otherwise, vectors as `[x, y, z]`, an unset optional as nothing.
class DefaultText {
 public:
  /// A double as the shortest text that reads back to it, with ".0" when it is whole.
  static std::string of(double value) {
    std::ostringstream out;
    out.precision(15);
    out << value;
    std::string text = out.str();
    if (std::isfinite(value) && text.find_first_of(".e") == std::string::npos) text += ".0";
    return text;
  }
  /// An integer in decimal.
  static std::string of(int value) { return std::to_string(value); }
  /// An unsigned integer in decimal.
  static std::string of(std::uint32_t value) { return std::to_string(value); }
  /// true or false.
  static std::string of(bool value) { return value ? "true" : "false"; }
  /// Plain when safe, else double-quoted ("" for the empty text).
  static std::string of(const std::string& value) {
    if (isPlainText(value)) return value;
    std::string quoted = "\"";
    for (const char c : value) {
      if (c == '"' || c == '\\') quoted += '\\';
      quoted += c;
    }
    return quoted + "\"";
  }
  /// The policy's name.
  static std::string of(UnknownAs value) { return toString(value); }
  /// The value, or nothing when unset.
  static std::string of(const std::optional<bool>& value) { return value ? of(*value) : ""; }
  /// `[x, y, z]`.
  template <class Scalar, int kRows>
  static std::string of(const Eigen::Matrix<Scalar, kRows, 1>& value) {
    std::string text = "[";
    for (int i = 0; i < kRows; ++i) text += (i == 0 ? "" : ", ") + of(value[i]);
    return text + "]";
  }

 private:
  /// Starts with a letter, holds only letters, digits, '_', '.', '/', '-', and is no YAML word
  /// (true, null, ...) that would read as something else.
  static bool isPlainText(const std::string& text) {
    if (text.empty() || !std::isalpha(static_cast<unsigned char>(text[0]))) return false;
    for (const char c : text) {
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '.' && c != '/' &&
          c != '-') {
        return false;
      }
    }
    std::string lower;
    for (const char c : text)
      lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    for (const char* word : {"true", "false", "yes", "no", "on", "off", "y", "n", "null"}) {
      if (lower == word) return false;
    }
    return true;
  }
};

/// Writes the commented default YAML text of a config struct: one line per key,
/// `key: default  # meaning [unit]`, comments aligned at kCommentColumn, nested sections
/// indented by two spaces, a blank line before every top-level section.
class CommentedYamlWriter {
 public:
  /// Column of the '#' of the comments (when the key and value leave room).
  static constexpr std::size_t kCommentColumn = 26;

  /// Writes the key line.
  template <class T>
  void key(const char* name, const T& field, const char* unit, const char* doc) {
    const std::string value = DefaultText::of(field);
    std::string meaning = doc;
    if (*unit != '\0') meaning += std::string(" [") + unit + "]";
    line(std::string(name) + ":" + (value.empty() ? "" : " " + value), meaning);
  }
  /// Writes `name:  # doc` and the keys of `sub` below it.
  template <class S>
  void section(const char* name, const S& sub, const char* doc) {
    if (indent_ == 0 && !text_.empty()) text_ += "\n";
    line(std::string(name) + ":", doc);
    indent_ += 2;
    visitConfig(sub, *this);
    indent_ -= 2;
  }
  /// The text written so far.
  [[nodiscard]] const std::string& text() const { return text_; }

 private:
  /// `content` at the current indent, then the comment (each further line of `comment`
  /// continues under the first, indented by "#   ").
  void line(const std::string& content, const std::string& comment) {
    std::string out = std::string(indent_, ' ') + content;
    std::istringstream lines(comment);
    std::string part;
    bool first = true;
    while (std::getline(lines, part)) {
      if (first) {
        out +=
            out.size() + 2 <= kCommentColumn ? std::string(kCommentColumn - out.size(), ' ') : "  ";
        out += "# " + part;
        first = false;
      } else {
        out += "\n" + std::string(kCommentColumn, ' ') + "#   " + part;
      }
    }
    text_ += out + "\n";
  }

  std::string text_;
  std::size_t indent_ = 0;
};

/// Writes the Markdown key reference of a config struct: one table row per key,
/// `| section.key | default | unit | meaning |`, and a row per section with its meaning.
class MarkdownKeyTable {
 public:
  /// Keys are named under `path` ("" for top-level sections).
  explicit MarkdownKeyTable(std::string path = "") : path_(std::move(path)) {}

  /// The header row and its separator.
  static std::string header() { return "| key | default | unit | meaning |\n|---|---|---|---|\n"; }
  /// Writes the key's row.
  template <class T>
  void key(const char* name, const T& field, const char* unit, const char* doc) {
    const std::string value = DefaultText::of(field);
    rows_ += "| `" + childPath(path_, name) + "` | " +
             (value.empty() ? "(empty)" : "`" + value + "`") + " | " + unit + " | " + cell(doc) +
             " |\n";
  }
  /// Writes the section's row, then the rows of its keys.
  template <class S>
  void section(const char* name, const S& sub, const char* doc) {
    const std::string path = childPath(path_, name);
    rows_ += "| **`" + path + "`** | | | " + cell(doc) + " |\n";
    MarkdownKeyTable nested(path);
    visitConfig(sub, nested);
    rows_ += nested.rows_;
  }
  /// The rows written so far (without the header).
  [[nodiscard]] const std::string& rows() const { return rows_; }

 private:
  /// `text` as one table cell: line breaks become spaces, '|' and '<' (which would start an HTML
  /// tag, as in `rt/<ns>`) are escaped.
  static std::string cell(const std::string& text) {
    std::string out;
    for (const char c : text) {
      if (c == '\n') {
        out += ' ';
      } else if (c == '|') {
        out += "\\|";
      } else if (c == '<') {
        out += "&lt;";
      } else {
        out += c;
      }
    }
    return out;
  }

  std::string path_;
  std::string rows_;
};

/// Collects the names of the top-level sections a config struct lists (keys are ignored).
class SectionNames {
 public:
  /// Ignores keys.
  template <class T>
  void key(const char* /*name*/, const T& /*field*/, const char* /*unit*/, const char* /*doc*/) {}
  /// Records `name`.
  template <class S>
  void section(const char* name, const S& /*sub*/, const char* /*doc*/) {
    names_.emplace_back(name);
  }
  /// The names, in the order listed.
  [[nodiscard]] const std::vector<std::string>& names() const { return names_; }

 private:
  std::vector<std::string> names_;
};

}  // namespace mlmap::config

#pragma once
/// @file
/// Strict reading of YAML configuration files: every key of a mapping must be read by the code
/// (an unknown key is an error naming it), every value must convert to the field's type, and
/// every problem is collected so that one run reports all of them. Used by the engine loader
/// (config_yaml.h) and by loaders of other sections of the same file (mlmap_node's `dds`).

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace mlmap::config {

/// Reads the keys of one YAML mapping into typed fields, remembering every problem as
/// "<path>.<key>: what is wrong". When it goes out of scope it reports every key of the mapping
/// that no read() / readVector() / child() asked for as an unknown key. A missing key leaves the
/// field untouched (its default applies); a null node (`section:` with nothing under it) reads
/// as an empty mapping.
class Section {
 public:
  /// `path` is the dotted name of this mapping ("" for the document's top level, whose error
  /// messages then start with '.': throwConfigErrors() drops it).
  Section(const YAML::Node& node, std::string path, std::vector<std::string>* errors)
      : node_(node), path_(std::move(path)), errors_(errors) {
    if (node_ && !node_.IsMap() && !node_.IsNull()) {
      errors_->push_back(path_ + ": must be a mapping of keys to values");
      node_ = YAML::Node();
    }
  }
  ~Section() {
    if (!node_ || !node_.IsMap()) return;
    for (const auto& kv : node_) {
      // A list, a mapping or null as a key (`[a, b]: 1`, `~: 1`) names no field;
      // as<std::string>() would throw out of this destructor.
      if (!kv.first.IsScalar()) {
        errors_->push_back((path_.empty() ? "(top level)" : path_) +
                           ": a key must be plain text, not " +
                           (kv.first.IsSequence() ? "a list"
                            : kv.first.IsMap()    ? "a mapping"
                                                  : "null"));
        continue;
      }
      const std::string key = kv.first.Scalar();
      if (known_.count(key) == 0) {
        std::string allowed;
        for (const std::string& k : known_) allowed += (allowed.empty() ? "" : ", ") + k;
        errors_->push_back(path_ + "." + key + ": unknown key (known keys: " + allowed + ")");
      }
    }
  }
  Section(const Section&) = delete;
  Section& operator=(const Section&) = delete;

  /// Reads `key` into `value` when present; a value of the wrong type is an error. For text, a
  /// null value (`key:` with nothing after it, or `~`) reads as the empty string.
  template <typename T>
  void read(const std::string& key, T* value) {
    known_.insert(key);
    if (!node_ || !node_.IsMap() || !node_[key]) return;
    if constexpr (std::is_same_v<T, std::string>) {
      if (node_[key].IsNull()) {
        value->clear();
        return;
      }
    }
    try {
      *value = node_[key].template as<T>();
    } catch (const YAML::Exception&) {
      errors_->push_back(path_ + "." + key + ": cannot read '" + YAML::Dump(node_[key]) + "' as " +
                         typeName(value));
    }
  }
  /// Reads `key` as a list of exactly value->size() numbers into a fixed-size Eigen vector.
  template <typename Vec>
  void readVector(const std::string& key, Vec* value) {
    known_.insert(key);
    if (!node_ || !node_.IsMap() || !node_[key]) return;
    const YAML::Node v = node_[key];
    if (!v.IsSequence() || static_cast<int>(v.size()) != value->size()) {
      errors_->push_back(path_ + "." + key + ": must be a list of " +
                         std::to_string(value->size()) + " numbers");
      return;
    }
    try {
      for (int i = 0; i < value->size(); ++i) {
        (*value)[i] = v[static_cast<std::size_t>(i)].template as<typename Vec::Scalar>();
      }
    } catch (const YAML::Exception&) {
      errors_->push_back(path_ + "." + key + ": cannot read '" + YAML::Dump(v) + "' as numbers");
    }
  }
  /// Marks `key` as known and returns its node (an undefined node when absent), to be read by
  /// a nested Section.
  YAML::Node child(const std::string& key) {
    known_.insert(key);
    return (node_ && node_.IsMap()) ? node_[key] : YAML::Node();
  }
  /// Dotted path of this mapping.
  [[nodiscard]] const std::string& path() const { return path_; }
  /// Where this section (and its children) collect problems.
  [[nodiscard]] std::vector<std::string>* errors() const { return errors_; }

 private:
  static const char* typeName(const double*) { return "a number"; }
  static const char* typeName(const int*) { return "an integer"; }
  static const char* typeName(const std::uint32_t*) { return "a non-negative integer"; }
  static const char* typeName(const bool*) { return "true or false"; }
  static const char* typeName(const std::string*) { return "text"; }

  YAML::Node node_;
  std::string path_;
  std::vector<std::string>* errors_;
  std::set<std::string> known_;
};

/// Appends to `errors` every key that appears twice in a mapping of `node` or below it, as
/// "line L: key '<path>' appears twice (first on line M)" (YAML forbids it; yaml-cpp would
/// silently keep the first value). Nesting deeper than `max_depth`, or more nodes than
/// `*node_budget` (aliases can make a small text a huge tree), is an error too.
inline void findDuplicateKeys(const YAML::Node& node, const std::string& path, int max_depth,
                              long* node_budget, std::vector<std::string>* errors) {
  if (--*node_budget < 0) return;  // reported once by the caller
  if (max_depth < 0) {
    errors->push_back("line " + std::to_string(node.Mark().line + 1) + ": '" + path +
                      "' is nested too deeply for a configuration");
    return;
  }
  if (node.IsSequence()) {
    std::size_t i = 0;
    for (const YAML::Node& item : node) {
      findDuplicateKeys(item, path + "[" + std::to_string(i++) + "]", max_depth - 1, node_budget,
                        errors);
    }
    return;
  }
  if (!node.IsMap()) return;
  std::map<std::string, int> first_line;  // key -> the line (1-based) it first appears on
  for (const auto& entry : node) {
    const std::string key = entry.first.IsScalar() ? entry.first.Scalar() : "<complex key>";
    const int line = entry.first.Mark().line + 1;
    const std::string key_path = path.empty() ? key : path + "." + key;
    const auto [first, inserted] = first_line.emplace(key, line);
    if (!inserted) {
      errors->push_back("line " + std::to_string(line) + ": key '" + key_path +
                        "' appears twice (first on line " + std::to_string(first->second) + ")");
    }
    findDuplicateKeys(entry.second, key_path, max_depth - 1, node_budget, errors);
  }
}

/// A YAML event handler that ignores every event: counts documents without building them.
class YamlEventSink : public YAML::EventHandler {
 public:
  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

/// True when `text` holds more than one YAML document. At most two are parsed (yaml-cpp's
/// LoadAll() can loop forever on malformed text).
inline bool hasSecondYamlDocument(const std::string& text) {
  std::istringstream stream(text);
  YAML::Parser parser(stream);
  YamlEventSink sink;
  return parser.HandleNextDocument(sink) && parser.HandleNextDocument(sink);
}

/// Parses one YAML document strictly: a syntax error, a second document ("---") or a key that
/// appears twice in a mapping throws std::runtime_error "<source_name>: ..." naming the line.
inline YAML::Node parseYamlDocument(const std::string& text, const std::string& source_name) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
    if (hasSecondYamlDocument(text)) {
      throw std::runtime_error(source_name +
                               ": more than one YAML document (separated by "
                               "'---'); a configuration is one document: merge them or remove "
                               "the extra ones");
    }
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(source_name + ": not valid YAML: " + e.what());
  }
  std::vector<std::string> errors;
  constexpr int kMaxDepth = 32;
  long node_budget = 100000;  // configurations have a few hundred nodes
  findDuplicateKeys(root, "", kMaxDepth, &node_budget, &errors);
  if (node_budget < 0)
    errors.push_back("more than 100000 YAML nodes: too large for a configuration");
  if (!errors.empty()) {
    std::string m = source_name + ": not a valid configuration:";
    for (const std::string& e : errors) m += "\n  " + e;
    throw std::runtime_error(m);
  }
  return root;
}

/// The whole text of a configuration file. Throws std::runtime_error "<path>: cannot open the
/// configuration file".
inline std::string readConfigFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open the configuration file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

/// Drops the leading '.' of problems found at the top level of a document (Section path "").
inline void stripTopLevelDots(std::vector<std::string>* errors) {
  for (std::string& e : *errors) {
    if (!e.empty() && e[0] == '.') e.erase(0, 1);
  }
}

/// Throws std::runtime_error "<source_name>: invalid mlmap configuration:" followed by one
/// problem per line.
[[noreturn]] inline void throwConfigErrors(const std::string& source_name,
                                           const std::vector<std::string>& errors) {
  std::ostringstream out;
  out << source_name << ": invalid mlmap configuration:";
  for (const std::string& e : errors) out << "\n  " << e;
  throw std::runtime_error(out.str());
}

}  // namespace mlmap::config

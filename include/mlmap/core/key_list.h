#pragma once
/// @file
/// Walking the key lists of config structs (standard library only, so that every library can
/// name keys from them). A config struct lists its keys once in a static
/// `template <class Self, class V> static void visit(Self& self, V& visitor)` (Self: the struct
/// or a const one), calling for each key
///   `visitor.key(const char* name, T& field, const char* unit, const char* doc)` and for each
/// nested section `visitor.section(const char* name, S& sub, const char* doc)`.
/// See mlmap/core/config.h for the engine's and mlmap/config/config_keys.h for the visitors that
/// read, write and document YAML.

#include <string>
#include <type_traits>
#include <utility>

namespace mlmap {

/// Walks the keys of config struct `config` (const or not) with `visitor`: C::visit(config,
/// visitor).
template <class C, class V>
void visitConfig(C& config, V& visitor) {
  std::remove_const_t<C>::visit(config, visitor);
}

/// A visitor that finds the dotted key path of one field (of type T) in a key list, nested
/// sections included ("" when the list does not hold it). Used through keyPath().
template <class T>
class KeyPathFinder {
 public:
  /// Looks for `field`; paths start with `prefix` ("" at the top).
  KeyPathFinder(const T& field, std::string prefix) : field_(&field), prefix_(std::move(prefix)) {}

  /// Records `name` when `field` is the field sought.
  template <class F>
  void key(const char* name, const F& field, const char* /*unit*/, const char* /*doc*/) {
    check(name, field);
  }
  /// Records `name` when `sub` is the field sought, else looks inside it.
  template <class S>
  void section(const char* name, const S& sub, const char* /*doc*/) {
    check(name, sub);
    KeyPathFinder nested(*field_, join(name));
    visitConfig(sub, nested);
    if (!nested.path_.empty()) path_ = nested.path_;
  }
  /// The path found ("" when none).
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  template <class F>
  void check(const char* name, const F& field) {
    // A struct and its first field share an address: the type tells them apart.
    if constexpr (std::is_same_v<F, T>) {
      if (&field == field_) path_ = join(name);
    }
  }
  [[nodiscard]] std::string join(const char* name) const {
    return prefix_.empty() ? std::string(name) : prefix_ + "." + name;
  }

  const T* field_;
  std::string prefix_;
  std::string path_;
};

/// The dotted key path of `field`, a member (or a member of a nested section) of `config`, as
/// its key list names it: keyPath(map_config, map_config.awareness.rho_cells) ==
/// "awareness.rho_cells". Messages name keys this way, so a key name is written once.
template <class C, class T>
std::string keyPath(const C& config, const T& field) {
  KeyPathFinder<T> finder(field, "");
  visitConfig(config, finder);
  return finder.path();
}

}  // namespace mlmap

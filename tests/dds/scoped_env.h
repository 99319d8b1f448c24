#pragma once
/// @file
/// Test helper: sets or unsets an environment variable for one scope.

#include <cstdlib>
#include <optional>
#include <string>

namespace mlmap::dds::test_support {

/// Sets (or unsets, with nullopt) an environment variable for the lifetime of the object and
/// restores the previous state afterwards.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::optional<std::string>& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) {
      ::setenv(name, value->c_str(), 1);
    } else {
      ::unsetenv(name);
    }
  }
  ~ScopedEnv() {
    if (old_) {
      ::setenv(name_, old_->c_str(), 1);
    } else {
      ::unsetenv(name_);
    }
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> old_;
};

}  // namespace mlmap::dds::test_support

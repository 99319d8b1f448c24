#pragma once
// Checking error messages: a test of bad input asserts what the message says.

#include <gtest/gtest.h>

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlmap::testing {

/// Expects `fn` to throw `Exception` whose message contains every one of `parts`.
template <typename Exception = std::runtime_error>
void expectThrowWith(const std::function<void()>& fn, const std::vector<std::string>& parts) {
  try {
    fn();
    ADD_FAILURE() << "expected an exception mentioning '" << parts.front() << "'";
  } catch (const Exception& e) {
    const std::string message = e.what();
    for (const std::string& part : parts) {
      EXPECT_NE(message.find(part), std::string::npos)
          << "message '" << message << "' does not mention '" << part << "'";
    }
  }
}

}  // namespace mlmap::testing

#pragma once
/// @file
/// Counts the bytes a test binary allocates through operator new (allocation_counter.cpp replaces
/// the global operator new and delete: link it into a binary of its own). A scope measures the
/// peak of live bytes while it lasts and may cap them: an allocation beyond the cap throws
/// std::bad_alloc instead of taking the memory, so a test of a bug that would allocate
/// gigabytes fails quickly and cheaply on the buggy code.

#include <cstddef>

namespace mlmap::test_support {

/// Measures allocations from its construction to its destruction (scopes do not nest).
class AllocationScope {
 public:
  /// Starts measuring; `cap_bytes` > 0 refuses (std::bad_alloc) any allocation that would take the
  /// live bytes allocated in the scope beyond it.
  explicit AllocationScope(std::size_t cap_bytes = 0);
  ~AllocationScope();
  AllocationScope(const AllocationScope&) = delete;
  AllocationScope& operator=(const AllocationScope&) = delete;

  /// Most bytes live at once in the scope, beyond those live when it began [bytes].
  [[nodiscard]] std::size_t peakBytes() const;
  /// Whether an allocation was refused for the cap.
  [[nodiscard]] bool capHit() const;
  /// The largest single allocation refused for the cap [bytes] (0: none).
  [[nodiscard]] std::size_t largestRefusedBytes() const;
};

}  // namespace mlmap::test_support

#include "allocation_counter.h"

#include <atomic>
#include <cstdlib>
#include <new>

namespace {

constexpr std::size_t kHeaderBytes =
    16;  // the size, kept before each block (keeps 16-byte alignment)

std::atomic<std::size_t> g_live_bytes{0};
std::atomic<std::size_t> g_peak_bytes{0};
std::atomic<std::size_t> g_scope_base_bytes{0};
std::atomic<std::size_t> g_cap_bytes{0};  // 0: no cap
std::atomic<std::size_t> g_largest_refused_bytes{0};
std::atomic<bool> g_cap_hit{false};

void* allocate(std::size_t bytes) {
  const std::size_t cap = g_cap_bytes.load();
  const std::size_t live = g_live_bytes.fetch_add(bytes) + bytes;
  if (cap > 0 && live > g_scope_base_bytes.load() + cap) {
    g_live_bytes.fetch_sub(bytes);
    g_cap_hit = true;
    if (bytes > g_largest_refused_bytes.load()) g_largest_refused_bytes = bytes;
    throw std::bad_alloc();
  }
  std::size_t peak = g_peak_bytes.load();
  while (live > peak && !g_peak_bytes.compare_exchange_weak(peak, live)) {
  }
  void* block = std::malloc(bytes + kHeaderBytes);
  if (block == nullptr) {
    g_live_bytes.fetch_sub(bytes);
    throw std::bad_alloc();
  }
  *static_cast<std::size_t*>(block) = bytes;
  return static_cast<char*>(block) + kHeaderBytes;
}

void release(void* p) noexcept {
  if (p == nullptr) return;
  char* block = static_cast<char*>(p) - kHeaderBytes;
  g_live_bytes.fetch_sub(*reinterpret_cast<std::size_t*>(block));
  std::free(block);
}

}  // namespace

void* operator new(std::size_t bytes) { return allocate(bytes); }
void* operator new[](std::size_t bytes) { return allocate(bytes); }
void* operator new(std::size_t bytes, const std::nothrow_t&) noexcept {
  try {
    return allocate(bytes);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t bytes, const std::nothrow_t&) noexcept {
  try {
    return allocate(bytes);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void operator delete(void* p) noexcept { release(p); }
void operator delete[](void* p) noexcept { release(p); }
void operator delete(void* p, std::size_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t) noexcept { release(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { release(p); }

namespace mlmap::test_support {

AllocationScope::AllocationScope(std::size_t cap_bytes) {
  g_scope_base_bytes = g_live_bytes.load();
  g_peak_bytes = g_live_bytes.load();
  g_cap_hit = false;
  g_largest_refused_bytes = 0;
  g_cap_bytes = cap_bytes;
}

AllocationScope::~AllocationScope() { g_cap_bytes = 0; }

std::size_t AllocationScope::peakBytes() const {
  return g_peak_bytes.load() - g_scope_base_bytes.load();
}

bool AllocationScope::capHit() const { return g_cap_hit.load(); }

std::size_t AllocationScope::largestRefusedBytes() const { return g_largest_refused_bytes.load(); }

}  // namespace mlmap::test_support

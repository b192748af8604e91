#include "tests/support/alloc_counter.hpp"

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <new>

// glibc's own allocator entry points (exported for exactly this kind of interposition).
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void* __libc_valloc(std::size_t);
void* __libc_pvalloc(std::size_t);
void __libc_free(void*);
}

namespace {
thread_local bool t_counting = false;
thread_local std::uint64_t t_count = 0;
inline void note() {
  if (t_counting) {
    ++t_count;
    if (std::getenv("CAIRN_ALLOC_TRAP")) __builtin_trap();  // find the allocation under a debugger
  }
}
constexpr bool power_of_two(std::size_t a) { return a != 0 && (a & (a - 1)) == 0; }

void* aligned_or_throw(std::size_t n, std::align_val_t al) {
  const auto a = static_cast<std::size_t>(al);
  if (void* p = __libc_memalign(a < sizeof(void*) ? sizeof(void*) : a, n ? n : 1)) return p;
  throw std::bad_alloc();
}
}  // namespace

namespace cairn::testing {
void start_counting_allocations() {
  t_count = 0;
  t_counting = true;
}
std::uint64_t stop_counting_allocations() {
  t_counting = false;
  return t_count;
}
std::uint64_t allocations_so_far() { return t_count; }
}  // namespace cairn::testing

// ---- C allocation functions: every one that hands out memory counts once per call.
extern "C" {
void* malloc(std::size_t n) {
  note();
  return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) {
  note();
  return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) {
  note();
  return __libc_realloc(p, n);
}
void* reallocarray(void* p, std::size_t count, std::size_t size) {
  note();
  std::size_t bytes = 0;
  if (__builtin_mul_overflow(count, size, &bytes)) {
    errno = ENOMEM;
    return nullptr;
  }
  return __libc_realloc(p, bytes);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t n) {
  note();
  if (!power_of_two(alignment) || alignment % sizeof(void*) != 0) return EINVAL;
  void* p = __libc_memalign(alignment, n);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}
void* aligned_alloc(std::size_t alignment, std::size_t n) {
  note();
  if (!power_of_two(alignment)) {
    errno = EINVAL;
    return nullptr;
  }
  return __libc_memalign(alignment, n);
}
void* memalign(std::size_t alignment, std::size_t n) {
  note();
  return __libc_memalign(alignment, n);
}
void* valloc(std::size_t n) {
  note();
  return __libc_valloc(n);
}
void* pvalloc(std::size_t n) {
  note();
  return __libc_pvalloc(n);
}
void free(void* p) { __libc_free(p); }
}

// ---- C++ replaceable allocation functions: plain, array, nothrow, aligned (align_val_t).
void* operator new(std::size_t n) {
  note();
  if (void* p = __libc_malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  note();
  if (void* p = __libc_malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  note();
  return __libc_malloc(n ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  note();
  return __libc_malloc(n ? n : 1);
}
void* operator new(std::size_t n, std::align_val_t al) {
  note();
  return aligned_or_throw(n, al);
}
void* operator new[](std::size_t n, std::align_val_t al) {
  note();
  return aligned_or_throw(n, al);
}
void* operator new(std::size_t n, std::align_val_t al, const std::nothrow_t&) noexcept {
  note();
  const auto a = static_cast<std::size_t>(al);
  return __libc_memalign(a < sizeof(void*) ? sizeof(void*) : a, n ? n : 1);
}
void* operator new[](std::size_t n, std::align_val_t al, const std::nothrow_t&) noexcept {
  note();
  const auto a = static_cast<std::size_t>(al);
  return __libc_memalign(a < sizeof(void*) ? sizeof(void*) : a, n ? n : 1);
}

void operator delete(void* p) noexcept { __libc_free(p); }
void operator delete[](void* p) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { __libc_free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { __libc_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { __libc_free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { __libc_free(p); }

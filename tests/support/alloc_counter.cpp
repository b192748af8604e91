#include "tests/support/alloc_counter.hpp"

#include <cstdlib>
#include <new>

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
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
void free(void* p) { __libc_free(p); }
}

void* operator new(std::size_t n) {
  note();
  if (void* p = __libc_malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void operator delete(void* p) noexcept { __libc_free(p); }
void operator delete[](void* p) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t) noexcept { __libc_free(p); }

// The counting allocator counts every allocation function, once per call, and frees
// count nothing. Each result escapes through a volatile pointer, so the compiler cannot
// elide an allocation/free pair (GCC's -fallocation-dce would).
#include "tests/support/alloc_counter.hpp"

#include <malloc.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <memory>
#include <new>
#include <vector>

namespace cairn::testing {
namespace {

void* volatile g_sink = nullptr;

template <typename F>
std::uint64_t count(F&& allocate) {
  start_counting_allocations();
  allocate();
  return stop_counting_allocations();
}

bool aligned(const void* p, std::size_t a) { return reinterpret_cast<std::uintptr_t>(p) % a == 0; }

struct alignas(64) Over {
  char bytes[64];
};

TEST(AllocCounter, EveryCFunctionCountsOnce) {
  EXPECT_EQ(count([] { g_sink = std::malloc(24); }), 1u) << "malloc";
  std::free(g_sink);
  EXPECT_EQ(count([] { g_sink = std::calloc(3, 8); }), 1u) << "calloc";
  void* p = g_sink;
  EXPECT_EQ(count([&] { g_sink = std::realloc(p, 4096); }), 1u) << "realloc";
  p = g_sink;
  EXPECT_EQ(count([&] { g_sink = reallocarray(p, 16, 512); }), 1u) << "reallocarray";
  std::free(g_sink);
  void* pm = nullptr;
  EXPECT_EQ(count([&] { ASSERT_EQ(posix_memalign(&pm, 128, 100), 0); }), 1u) << "posix_memalign";
  EXPECT_TRUE(aligned(pm, 128));
  std::free(pm);
  EXPECT_EQ(count([] { g_sink = std::aligned_alloc(256, 512); }), 1u) << "aligned_alloc";
  EXPECT_TRUE(aligned(g_sink, 256));
  std::free(g_sink);
  EXPECT_EQ(count([] { g_sink = memalign(64, 10); }), 1u) << "memalign";
  EXPECT_TRUE(aligned(g_sink, 64));
  std::free(g_sink);
  EXPECT_EQ(count([] { g_sink = valloc(10); }), 1u) << "valloc";
  EXPECT_TRUE(aligned(g_sink, 4096));
  std::free(g_sink);
  EXPECT_EQ(count([] { g_sink = pvalloc(10); }), 1u) << "pvalloc";
  std::free(g_sink);
  g_sink = std::malloc(8);
  EXPECT_EQ(count([] { std::free(g_sink); }), 0u) << "free is not an allocation";
}

TEST(AllocCounter, EveryOperatorNewCountsOnce) {
  EXPECT_EQ(count([] { g_sink = ::operator new(24); }), 1u) << "new";
  ::operator delete(g_sink);
  EXPECT_EQ(count([] { g_sink = ::operator new[](24); }), 1u) << "new[]";
  ::operator delete[](g_sink);
  EXPECT_EQ(count([] { g_sink = ::operator new(24, std::nothrow); }), 1u) << "new nothrow";
  ::operator delete(g_sink, std::nothrow);
  EXPECT_EQ(count([] { g_sink = ::operator new[](24, std::nothrow); }), 1u) << "new[] nothrow";
  ::operator delete[](g_sink, std::nothrow);
  EXPECT_EQ(count([] { g_sink = ::operator new(24, std::align_val_t{128}); }), 1u) << "aligned new";
  EXPECT_TRUE(aligned(g_sink, 128));
  ::operator delete(g_sink, std::align_val_t{128});
  EXPECT_EQ(count([] { g_sink = ::operator new[](24, std::align_val_t{128}); }), 1u) << "aligned new[]";
  EXPECT_TRUE(aligned(g_sink, 128));
  ::operator delete[](g_sink, std::align_val_t{128});
  EXPECT_EQ(count([] { g_sink = ::operator new(24, std::align_val_t{128}, std::nothrow); }), 1u) << "aligned new nothrow";
  EXPECT_TRUE(aligned(g_sink, 128));
  ::operator delete(g_sink, std::align_val_t{128}, std::nothrow);
  EXPECT_EQ(count([] { g_sink = ::operator new[](24, std::align_val_t{128}, std::nothrow); }), 1u) << "aligned new[] nothrow";
  EXPECT_TRUE(aligned(g_sink, 128));
  ::operator delete[](g_sink, std::align_val_t{128}, std::nothrow);
  // What code actually writes: new-expressions and containers of over-aligned types.
  EXPECT_EQ(count([] { g_sink = new Over; }), 1u) << "new Over";
  EXPECT_TRUE(aligned(g_sink, 64));
  delete static_cast<Over*>(g_sink);
  EXPECT_EQ(count([] { g_sink = new Over[3]; }), 1u) << "new Over[3]";
  delete[] static_cast<Over*>(g_sink);
  std::vector<Over> v;
  EXPECT_EQ(count([&] { v.resize(5); g_sink = v.data(); }), 1u) << "vector<Over>";
  EXPECT_TRUE(aligned(v.data(), 64));
  EXPECT_EQ(count([] { g_sink = std::make_unique<int>(7).release(); }), 1u) << "make_unique";
  delete static_cast<int*>(g_sink);
}

TEST(AllocCounter, CountsOnlyWhileCountingAndOnlyThisThread) {
  g_sink = std::malloc(8);  // not counting: no effect
  std::free(g_sink);
  start_counting_allocations();
  EXPECT_EQ(allocations_so_far(), 0u);
  g_sink = std::malloc(8);
  std::free(g_sink);
  EXPECT_EQ(allocations_so_far(), 1u);
  EXPECT_EQ(stop_counting_allocations(), 1u);
}

}  // namespace
}  // namespace cairn::testing

// Test support: counts heap allocations made by the calling thread while counting is on.
// Linking alloc_counter.cpp into a test binary replaces every allocation function with a
// counting version forwarding to glibc: malloc, calloc, realloc, reallocarray,
// posix_memalign, aligned_alloc, memalign, valloc, pvalloc, and every replaceable
// operator new / new[] (plain, nothrow, align_val_t, align_val_t + nothrow; the matching
// deletes free). alloc_counter_test proves each one counts.
#pragma once

#include <cstdint>

namespace cairn::testing {

/// Starts counting this thread's allocations (resets its count).
void start_counting_allocations();
/// Stops counting; returns the number of allocations since start.
std::uint64_t stop_counting_allocations();
/// Allocations counted so far on this thread (while counting).
std::uint64_t allocations_so_far();

}  // namespace cairn::testing

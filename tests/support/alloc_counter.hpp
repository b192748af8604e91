// Test support: counts heap allocations made by the calling thread while counting is on.
// Linking alloc_counter.cpp into a test binary replaces the global operator new/delete
// and malloc/calloc/realloc with counting versions (forwarding to glibc).
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

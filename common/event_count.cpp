#include "common/event_count.hpp"

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <ctime>

namespace cairn {

static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t) && std::atomic<std::uint32_t>::is_always_lock_free,
              "the futex word must be a plain 32-bit lock-free atomic");

void EventCount::notify() {
  count_.fetch_add(1, std::memory_order_acq_rel);
  // seq_cst pairs with the waiter's increment of waiters_ before it re-checks the count:
  // either it sees the new count, or we see it waiting and wake it.
  if (waiters_.load(std::memory_order_seq_cst) != 0) {
    syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&count_), FUTEX_WAKE_PRIVATE, INT_MAX, nullptr, nullptr, 0);
  }
}

bool EventCount::wait_until(std::uint32_t seen, Nanos deadline) const {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(deadline / kNanosPerSecond);
  ts.tv_nsec = static_cast<long>(deadline % kNanosPerSecond);
  waiters_.fetch_add(1, std::memory_order_seq_cst);
  bool moved = false;
  for (;;) {
    if (count_.load(std::memory_order_seq_cst) != seen) {
      moved = true;
      break;
    }
    // FUTEX_WAIT_BITSET takes an absolute CLOCK_MONOTONIC timeout; it returns at once
    // (EAGAIN) if the word is no longer `seen`.
    const long r = syscall(SYS_futex, const_cast<std::uint32_t*>(reinterpret_cast<const std::uint32_t*>(&count_)),
                           FUTEX_WAIT_BITSET_PRIVATE, seen, &ts, nullptr, FUTEX_BITSET_MATCH_ANY);
    if (r == -1 && errno == ETIMEDOUT) {
      moved = count_.load(std::memory_order_acquire) != seen;
      break;
    }
    // Woken, EAGAIN or EINTR: check again.
  }
  waiters_.fetch_sub(1, std::memory_order_seq_cst);
  return moved;
}

}  // namespace cairn

// A lock-free wake-up from one thread to another: the producer bumps a counter, the
// consumer sleeps until the counter moves or an absolute CLOCK_MONOTONIC deadline passes
// (a Linux futex). notify() makes a system call only while someone is waiting, allocates
// nothing and never blocks, so an RT or I/O thread may call it. Used to wake the RT loop
// when a scan arrives and the DDS side when a message is ready (docs/architecture.md).
#pragma once

#include <atomic>
#include <cstdint>

#include "common/clock.hpp"

namespace cairn {

class EventCount {
 public:
  /// The current count: read it before checking for work, then wait on it.
  std::uint32_t value() const { return count_.load(std::memory_order_acquire); }
  void notify();
  /// Until value() != seen or CLOCK_MONOTONIC >= deadline; true if it moved.
  bool wait_until(std::uint32_t seen, Nanos deadline) const;

 private:
  std::atomic<std::uint32_t> count_{0};
  mutable std::atomic<std::uint32_t> waiters_{0};
};

}  // namespace cairn

// A cyclictest-style witness of the time the platform takes away from one CPU. A
// SCHED_FIFO thread one priority above the thread under test, pinned to the same CPU,
// sleeps to an absolute 250 µs grid and records every wake-up later than 100 µs. Nothing
// in the process can delay it (it outranks every thread there), so each late wake-up is an
// interval in which the kernel, an interrupt or the hypervisor (a VM's stolen time) held
// that CPU, and the thread under test could not run either. A deadline miss of the thread
// under test is then Cairn's own only if it remains after subtracting that time.
#pragma once

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <optional>
#include <thread>
#include <vector>

#include "common/clock.hpp"

namespace cairn::testing {

/// The highest CPU this process may run on (the RT loop and its witness go there), or -1.
inline int last_allowed_cpu() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return -1;
  for (int c = CPU_SETSIZE - 1; c >= 0; --c) {
    if (CPU_ISSET(c, &set)) return c;
  }
  return -1;
}

class CpuStallWitness {
 public:
  static constexpr Nanos kGrid = 250 * 1000;      // the witness's wake-up grid
  static constexpr Nanos kLateFrom = 100 * 1000;  // a wake-up this late is a stall

  CpuStallWitness(int cpu, int priority) {
    stalls_.reserve(1 << 18);  // before the thread starts: it never allocates (4 MiB)
    thread_ = std::thread([this, cpu, priority] { run(cpu, priority); });
    while (!started_.load()) std::this_thread::yield();
  }
  ~CpuStallWitness() { stop(); }
  CpuStallWitness(const CpuStallWitness&) = delete;
  CpuStallWitness& operator=(const CpuStallWitness&) = delete;

  /// Whether the thread got SCHED_FIFO at its priority on its CPU (root only).
  bool granted() const { return granted_; }
  void stop() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
  }
  /// After stop(): time within [from, to] in which the witness was due but not running,
  /// and (if `count`) how many recorded stalls overlap it.
  Nanos stolen(Nanos from, Nanos to, std::size_t* count = nullptr) const {
    Nanos sum = 0;
    std::size_t n = 0;
    for (const Stall& s : stalls_) {
      const Nanos overlap = std::min(s.woke, to) - std::max(s.due, from);
      if (overlap > 0) {
        sum += overlap;
        ++n;
      }
    }
    if (count) *count = n;
    return sum;
  }
  /// Stalls not recorded because the log was full (the attribution is then incomplete).
  std::size_t dropped() const { return dropped_; }
  std::size_t stalls() const { return stalls_.size(); }
  Nanos longest() const {
    Nanos m = 0;
    for (const Stall& s : stalls_) m = std::max(m, s.woke - s.due);
    return m;
  }
  Nanos total() const { return stolen(0, INT64_MAX); }
  /// How many recorded stalls that began within [from, to] lasted longer than `d`.
  std::size_t longer_than(Nanos d, Nanos from, Nanos to) const {
    std::size_t n = 0;
    for (const Stall& s : stalls_) n += s.woke - s.due > d && s.due >= from && s.due <= to ? 1 : 0;
    return n;
  }

 private:
  struct Stall {
    Nanos due, woke;
  };
  static Nanos now() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);  // the clock of MonotonicClock
    return static_cast<Nanos>(ts.tv_sec) * kNanosPerSecond + ts.tv_nsec;
  }
  void run(int cpu, int priority) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(static_cast<unsigned>(cpu), &set);
    sched_param sp{};
    sp.sched_priority = priority;
    granted_ = pthread_setaffinity_np(pthread_self(), sizeof set, &set) == 0 &&
               pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp) == 0;
    started_ = true;
    Nanos due = now() + kGrid;
    while (running_.load(std::memory_order_relaxed)) {
      const timespec ts{static_cast<time_t>(due / kNanosPerSecond), static_cast<long>(due % kNanosPerSecond)};
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
      const Nanos woke = now();
      if (woke - due > kLateFrom) {
        if (stalls_.size() < stalls_.capacity()) stalls_.push_back({due, woke});
        else ++dropped_;
      }
      due += kGrid;
      if (due < woke) due = woke + kGrid;
    }
  }

  std::vector<Stall> stalls_;
  std::atomic<bool> running_{true}, started_{false};
  bool granted_ = false;  // written before started_, read after
  std::size_t dropped_ = 0;  // read after stop()
  std::thread thread_;
};

}  // namespace cairn::testing

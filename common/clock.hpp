// Time: a monotonic nanosecond clock behind an interface, so a simulation
// clock (driven by the HIL bench or a test) can replace the real one.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>

namespace cairn {

class EventCount;

using Nanos = std::int64_t;
constexpr Nanos kNanosPerSecond = 1'000'000'000;
constexpr Nanos kNanosPerMilli = 1'000'000;
constexpr Nanos kNanosPerMicro = 1'000;

/// A timeout as whole milliseconds for poll() and friends: rounded up (never shorter than
/// asked), 0 for past deadlines, capped at 1000 s.
constexpr int timeout_to_ms(Nanos timeout) {
  if (timeout <= 0) return 0;
  const Nanos ms = (timeout + kNanosPerMilli - 1) / kNanosPerMilli;
  return ms > 1'000'000 ? 1'000'000 : static_cast<int>(ms);
}

constexpr Nanos seconds_to_nanos(double s) { return static_cast<Nanos>(s * 1e9); }
constexpr double nanos_to_seconds(Nanos t) { return static_cast<double>(t) * 1e-9; }

class Clock {
 public:
  virtual ~Clock() = default;
  /// Monotonic time in nanoseconds. Never goes backwards.
  virtual Nanos now() const = 0;
  /// Blocks until now() >= deadline (absolute). Returns at once if already past.
  virtual void sleep_until(Nanos deadline) = 0;
  /// Blocks until `event` moves past `seen` or now() >= deadline; true if it moved. This
  /// default sleeps to the deadline (a simulated clock has no early wake-up); the
  /// monotonic clock wakes on the event at once.
  virtual bool wait_event(const EventCount& event, std::uint32_t seen, Nanos deadline);
};

/// CLOCK_MONOTONIC with absolute-deadline sleeps (clock_nanosleep TIMER_ABSTIME).
class MonotonicClock final : public Clock {
 public:
  Nanos now() const override;
  void sleep_until(Nanos deadline) override;
  bool wait_event(const EventCount& event, std::uint32_t seen, Nanos deadline) override;
  /// The process-wide instance (stateless, so sharing it is free).
  static MonotonicClock& instance();
};

/// A clock that only moves when told to. sleep_until() blocks the caller until
/// another thread advances the time past the deadline (or the clock is closed).
class SimClock final : public Clock {
 public:
  explicit SimClock(Nanos start = 0) : now_(start) {}
  Nanos now() const override { return now_.load(std::memory_order_acquire); }
  void sleep_until(Nanos deadline) override;
  /// Sets the time; ignored if it would go backwards. Wakes every sleeper whose deadline passed.
  void set(Nanos t);
  void advance(Nanos dt) { set(now() + dt); }
  /// Releases every sleeper for good (used at shutdown).
  void close();

 private:
  std::atomic<Nanos> now_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool closed_ = false;
};

}  // namespace cairn

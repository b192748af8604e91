#include "common/clock.hpp"

#include "common/event_count.hpp"

#include <cerrno>
#include <ctime>

namespace cairn {

Nanos MonotonicClock::now() const {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<Nanos>(ts.tv_sec) * kNanosPerSecond + ts.tv_nsec;
}

void MonotonicClock::sleep_until(Nanos deadline) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(deadline / kNanosPerSecond);
  ts.tv_nsec = static_cast<long>(deadline % kNanosPerSecond);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

bool Clock::wait_event(const EventCount& event, std::uint32_t seen, Nanos deadline) {
  sleep_until(deadline);
  return event.value() != seen;
}

bool MonotonicClock::wait_event(const EventCount& event, std::uint32_t seen, Nanos deadline) {
  return event.wait_until(seen, deadline);
}

MonotonicClock& MonotonicClock::instance() {
  static MonotonicClock clock;
  return clock;
}

void SimClock::sleep_until(Nanos deadline) {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [&] { return closed_ || now() >= deadline; });
}

void SimClock::set(Nanos t) {
  {
    std::lock_guard lock(mutex_);
    if (t > now_.load(std::memory_order_relaxed)) now_.store(t, std::memory_order_release);
  }
  cv_.notify_all();
}

void SimClock::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  cv_.notify_all();
}

}  // namespace cairn

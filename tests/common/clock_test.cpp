#include "common/clock.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace cairn {
namespace {

TEST(MonotonicClock, NeverGoesBackAndSleepsToDeadline) {
  auto& c = MonotonicClock::instance();
  Nanos prev = c.now();
  for (int i = 0; i < 1000; ++i) {
    const Nanos t = c.now();
    ASSERT_GE(t, prev);
    prev = t;
  }
  const Nanos deadline = c.now() + 2 * kNanosPerMilli;
  c.sleep_until(deadline);
  EXPECT_GE(c.now(), deadline);
  c.sleep_until(0);  // past deadline: returns at once
}

TEST(SimClock, SleepersWakeOnlyWhenTimeAdvances) {
  SimClock clock(100);
  EXPECT_EQ(clock.now(), 100);
  clock.set(50);  // never backwards
  EXPECT_EQ(clock.now(), 100);
  std::atomic<bool> woke{false};
  std::thread t([&] {
    clock.sleep_until(1000);
    woke = true;
  });
  clock.advance(500);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_FALSE(woke.load());
  clock.set(1000);
  t.join();
  EXPECT_TRUE(woke.load());
  EXPECT_EQ(clock.now(), 1000);
}

// Waits (real time, bounded) for `flag`; false if it did not come.
bool wait_for(const std::atomic<bool>& flag, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (!flag.load() && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return flag.load();
}

TEST(SimClock, CloseReleasesSleepers) {
  SimClock clock;
  std::atomic<bool> returned{false};
  std::thread t([&] {
    clock.sleep_until(kNanosPerSecond * 1000);
    returned = true;
  });
  EXPECT_FALSE(wait_for(returned, std::chrono::milliseconds(20))) << "the sleeper did not sleep";
  clock.close();
  const bool released = wait_for(returned, std::chrono::seconds(2));
  const Nanos at_release = clock.now();
  if (!released) clock.set(kNanosPerSecond * 1000);  // let the thread go, so the failure is a failure, not a hang
  t.join();
  EXPECT_TRUE(released) << "close() did not release the sleeper";
  EXPECT_EQ(at_release, 0) << "released by close(), not by time";
  // After close(), a new sleeper returns at once too.
  std::atomic<bool> late{false};
  std::thread t2([&] {
    clock.sleep_until(kNanosPerSecond * 2000);
    late = true;
  });
  const bool late_released = wait_for(late, std::chrono::seconds(2));
  if (!late_released) clock.set(kNanosPerSecond * 2000);
  t2.join();
  EXPECT_TRUE(late_released) << "a sleeper after close() blocked";
}

}  // namespace
}  // namespace cairn

#include "common/clock.hpp"

#include <gtest/gtest.h>

#include <atomic>
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

TEST(SimClock, CloseReleasesSleepers) {
  SimClock clock;
  std::thread t([&] { clock.sleep_until(kNanosPerSecond * 1000); });
  clock.close();
  t.join();
  SUCCEED();
}

}  // namespace
}  // namespace cairn

// The guard itself (single_threaded_guard.cpp): a test labelled single-threaded that starts
// a thread must fail. Registered with WILL_FAIL: it passes only if the thread aborts it.
#include <gtest/gtest.h>

#include <thread>

TEST(SingleThreadedGuard, StartingAThreadAborts) {
  std::thread t([] {});
  t.join();
}

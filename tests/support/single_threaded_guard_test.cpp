// The guard itself (single_threaded_guard.cpp): a test labelled single-threaded that starts
// a thread must fail. Registered with PASS_REGULAR_EXPRESSION: it passes only if the guard
// stopped it with its message (the guard exits 70; without the guard this test prints nothing
// of the kind and fails).
#include <gtest/gtest.h>

#include <thread>

TEST(SingleThreadedGuard, StartingAThreadAborts) {
  std::thread t([] {});
  t.join();
}

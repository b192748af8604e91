// Waits, bounded, for a condition another thread (a server's, a process's) makes true:
// polls it every 2 ms up to `limit`, then asks once more. The poll is not the logic under
// test; the limit only bounds a failing test.
#pragma once

#include <chrono>
#include <thread>

namespace cairn::testing {

template <typename F>
bool eventually(F done, std::chrono::milliseconds limit = std::chrono::seconds(5)) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return done();
}

}  // namespace cairn::testing

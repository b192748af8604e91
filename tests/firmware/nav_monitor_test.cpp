// The robot's stuck report (firmware/nav_monitor.hpp), on simulated time: stuck after
// stuck_after without getting progress_m away, whether blocked, turning in place or rocking;
// moving on resets the clock; safety stops other than the protective field pause it; a new
// task starts afresh.
#include "firmware/nav_monitor.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace cairn::firmware {
namespace {

constexpr Nanos kCycle = 50 * kNanosPerMilli;

struct Monitored {
  NavMonitor m{NavMonitorConfig{}};  // 5 s, 0.3 m
  Nanos t = 0;
  // Cycles for `seconds` with the position from `at(t)`; returns the last state.
  template <typename At>
  NavState go(double seconds, std::uint32_t task, StopReason stop, At at) {
    NavState s = NavState::kIdle;
    for (const Nanos end = t + static_cast<Nanos>(seconds * 1e9); t < end; t += kCycle) s = m.update(task, true, stop, at(t), t);
    return s;
  }
};

TEST(NavMonitor, HeldByTheFieldOrTurningInPlaceItIsStuckAfterFiveSeconds) {
  Monitored r;
  const auto still = [](Nanos) { return Vec2(2, 3); };
  EXPECT_EQ(r.go(4.9, 7, StopReason::kProtectiveField, still), NavState::kMoving);
  EXPECT_EQ(r.go(0.2, 7, StopReason::kProtectiveField, still), NavState::kStuck);
  EXPECT_EQ(r.m.stuck_reports(), 1u);
  EXPECT_EQ(r.m.task_id(), 7u);
  // Rocking 0.2 m back and forth (never 0.3 m from where it was): stuck too.
  Monitored k;
  const auto rocking = [](Nanos t) { return Vec2(0.2 * std::sin(1e-9 * static_cast<double>(t)), 0); };
  EXPECT_EQ(k.go(6.0, 3, StopReason::kNone, rocking), NavState::kStuck);
}

TEST(NavMonitor, ProgressKeepsItMovingSafetyStopsPauseItANewTaskStartsAfresh) {
  Monitored r;
  const auto driving = [](Nanos t) { return Vec2(0.1 * 1e-9 * static_cast<double>(t), 0); };  // 0.1 m/s
  EXPECT_EQ(r.go(30, 1, StopReason::kNone, driving), NavState::kMoving);
  // The e-stop holds it 10 s: stopped, not stuck; moving again the clock starts afresh.
  const Vec2 here = driving(r.t);
  const auto still = [&](Nanos) { return here; };
  EXPECT_EQ(r.go(10, 1, StopReason::kEstop, still), NavState::kStopped);
  EXPECT_EQ(r.go(4.5, 1, StopReason::kNone, still), NavState::kMoving);
  EXPECT_EQ(r.go(1.0, 1, StopReason::kNone, still), NavState::kStuck);
  // A new task: afresh.
  EXPECT_EQ(r.m.update(2, true, StopReason::kNone, here, r.t), NavState::kMoving);
  EXPECT_EQ(r.go(4.5, 2, StopReason::kNone, still), NavState::kMoving);
  // No task, or one that does not move it (idle): idle.
  EXPECT_EQ(r.m.update(2, false, StopReason::kNone, here, r.t), NavState::kIdle);
  EXPECT_EQ(r.m.update(0, true, StopReason::kNone, here, r.t), NavState::kIdle);
  EXPECT_EQ(r.m.stuck_reports(), 1u);
}

}  // namespace
}  // namespace cairn::firmware

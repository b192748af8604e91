// Real-time setup for the calling thread: SCHED_FIFO at a priority, CPU affinity, and
// (process-wide, once) mlockall. Each step that the process may not do is reported and
// skipped: the robot runs, with a warning, on a desktop or in a container.
#pragma once

#include <string>

namespace cairn::firmware {

struct RtRequest {
  int priority = 0;  // SCHED_FIFO 1..99; 0 = leave the scheduler alone
  int cpu = -1;      // -1 = no affinity
  bool lock_memory = false;
};

/// Applies what it can; returns a one-line summary ("SCHED_FIFO 80 on CPU 1, memory
/// locked" or "SCHED_FIFO refused (EPERM): running SCHED_OTHER; ...").
std::string apply_rt(const RtRequest& r);

}  // namespace cairn::firmware

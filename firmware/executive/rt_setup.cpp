#include "firmware/executive/rt_setup.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstring>

namespace cairn::firmware {

std::string apply_rt(const RtRequest& r) {
  std::string out;
  if (r.priority > 0) {
    sched_param sp{};
    sp.sched_priority = r.priority;
    const int e = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    out += e == 0 ? "SCHED_FIFO " + std::to_string(r.priority)
                  : std::string("SCHED_FIFO refused (") + std::strerror(e) + "): running SCHED_OTHER";
  } else {
    out += "SCHED_OTHER (no priority configured)";
  }
  if (r.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(static_cast<unsigned>(r.cpu), &set);
    const int e = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
    out += e == 0 ? ", on CPU " + std::to_string(r.cpu) : std::string(", affinity refused (") + std::strerror(e) + ")";
  }
  if (r.lock_memory) {
    out += mlockall(MCL_CURRENT | MCL_FUTURE) == 0 ? ", memory locked"
                                                    : std::string(", mlockall refused (") + std::strerror(errno) + ")";
  }
  return out;
}

}  // namespace cairn::firmware

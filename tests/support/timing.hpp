// Real-time bounds are claims about release builds. Sanitizer builds (ASan, TSan) run the
// same tests for memory and thread safety, 5-15x slower, so their timing bounds are scaled;
// so do cross-built tests running under qemu-user (CAIRN_EMULATED). A release build run
// inside the VM bench's software-emulated CPU (scripts/vm-bench.sh) is told so by the
// environment: CAIRN_TIMING_SLACK=5.
#pragma once

#include <cstdio>
#include <cstdlib>

namespace cairn::testing {

inline double timing_slack() {
#if defined(CAIRN_SANITIZED) || defined(CAIRN_EMULATED)
  constexpr double kBuilt = 5.0;
#else
  constexpr double kBuilt = 1.0;
#endif
  static const double slack = [] {
    const char* e = std::getenv("CAIRN_TIMING_SLACK");
    const double v = e ? std::atof(e) : 0.0;
    if (v <= kBuilt) return kBuilt;
    std::fprintf(stderr, "timing bounds scaled by %g (CAIRN_TIMING_SLACK)\n", v);  // never silently
    return v;
  }();
  return slack;
}

}  // namespace cairn::testing

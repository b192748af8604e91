// Real-time bounds are claims about release builds. Sanitizer builds (ASan, TSan) run the
// same tests for memory and thread safety, 5-15x slower, so their timing bounds are scaled.
#pragma once

namespace cairn::testing {

constexpr double timing_slack() {
#ifdef CAIRN_SANITIZED
  return 5.0;
#else
  return 1.0;
#endif
}

}  // namespace cairn::testing

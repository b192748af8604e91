// Real-time bounds are claims about release builds. Sanitizer builds (ASan, TSan) run the
// same tests for memory and thread safety, 5-15x slower, so their timing bounds are scaled;
// so do cross-built tests running under qemu-user (CAIRN_EMULATED).
#pragma once

namespace cairn::testing {

constexpr double timing_slack() {
#if defined(CAIRN_SANITIZED) || defined(CAIRN_EMULATED)
  return 5.0;
#else
  return 1.0;
#endif
}

}  // namespace cairn::testing

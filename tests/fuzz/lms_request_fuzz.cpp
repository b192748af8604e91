// libFuzzer target: the emulated LMS2xx receiving arbitrary host bytes (its request
// parser and command handling), so the HIL bench can never be crashed by a driver bug.
#include <cstddef>
#include <cstdint>

#include "hil/lms2xx/lms_device.hpp"

using namespace cairn;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const hil::World world = hil::World::parse("box 0 0 10 10\npole 5 5 0.05\n", "fuzz");
  hil::LmsDeviceConfig cfg;
  cfg.boot_time_s = 0;
  hil::LmsDevice dev(cfg, &world, [](Nanos) { return Pose2{2, 2, 0}; });
  dev.power_on(0);
  dev.poll(1, true);
  dev.receive({data, size}, 2);
  dev.poll(kNanosPerSecond, false);
  while (!dev.tx().empty()) dev.pop_tx();
  dev.on_tx_drained(kNanosPerSecond);
  return 0;
}

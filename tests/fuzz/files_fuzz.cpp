// libFuzzer target: the files people write or tools exchange. The first byte picks the
// parser (mod 4): a HIL world file (cairn-hil, cairn-map-quality), the base's
// landmarks.json or trajectories.csv, or the bench's truth file (all read by
// cairn-map-quality). Any bytes: a parsed result or std::runtime_error, nothing else.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "basestation/mapper/export.hpp"
#include "hil/world/world.hpp"
#include "tools/map_quality/pose_quality.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 4) {
      case 0: {
        const cairn::hil::World w = cairn::hil::World::parse(text, "fuzz.world");
        for (const auto& p : w.poles())
          if (!p.allFinite()) std::abort();
        break;
      }
      case 1:
        for (const auto& l : cairn::mapper::parse_landmarks_json(text, "fuzz.json"))
          if (!std::isfinite(l.x) || !std::isfinite(l.y)) std::abort();
        break;
      case 2: {
        const auto poses = cairn::mapper::parse_trajectories_csv(text, "fuzz.csv");
        for (const auto& p : poses)
          if (p.robot == 0 || !std::isfinite(p.pose.x) || !std::isfinite(p.pose.theta)) std::abort();
        cairn::tools::GroundTruth truth;  // scored against a fixed truth: the interpolation sees wild stamps
        truth.t0 = 1000;
        truth.robots[1] = {{0.0, {0, 0, 0}}, {0.1, {0.1, 0, 3.1}}, {0.2, {0.2, 0, -3.1}}};
        const cairn::tools::PoseQuality q = cairn::tools::evaluate_poses(poses, truth);
        if (!std::isfinite(q.rmse_m)) std::abort();
        break;
      }
      default: {
        const cairn::tools::GroundTruth g = cairn::tools::parse_ground_truth(text, "fuzz.truth");
        for (const auto& [id, v] : g.robots)
          for (const auto& smp : v)
            if (id == 0 || !std::isfinite(smp.t_s) || !std::isfinite(smp.pose.x)) std::abort();
        break;
      }
    }
  } catch (const std::runtime_error&) {
  }
  return 0;
}

#include "hil/lms2xx/scan_synth.hpp"

#include <numbers>

namespace cairn::hil {

void synthesize_sweep(const World& world, const Pose2& sensor, int angle_deg, int res_centideg, double max_range_m,
                      double range_noise_m, std::mt19937_64& rng, BeamSample* out, int own_robot) {
  const int n = sweep_beams(angle_deg, res_centideg);
  const double start_deg = angle_deg == 180 ? 0.0 : 40.0;  // 0° = right, 90° = ahead (sensor frame -90..+90)
  std::normal_distribution<double> noise(0.0, range_noise_m);
  for (int i = 0; i < n; ++i) {
    const double deg = start_deg + i * res_centideg / 100.0;
    const double a = sensor.theta + (deg - 90.0) * std::numbers::pi / 180.0;
    const RayHit h = world.cast(sensor.translation(), a, max_range_m, own_robot);
    out[i] = {h.hit ? h.range + noise(rng) : 0.0, h.hit, h.reflective};
  }
}

}  // namespace cairn::hil

// The LMS2xx's measurement model, shared by the emulator (which encodes it into
// telegrams) and cairn-sim (which hands it to the robot pipeline directly): one sweep of
// exact ray casts from the sensor's world pose, with Gaussian noise on each echo's range.
// Beam i looks at start + i·resolution, 0° = the sensor's right, 90° = ahead.
#pragma once

#include <random>

#include "hil/world/world.hpp"

namespace cairn::hil {

struct BeamSample {
  double range_m = 0;  // noisy range of the echo, 0 without one
  bool hit = false;
  bool reflective = false;
};

/// Beams in one sweep of `angle_deg` (100 or 180) at `res_centideg` (100, 50, 25).
constexpr int sweep_beams(int angle_deg, int res_centideg) { return angle_deg * 100 / res_centideg + 1; }

/// Fills out[0 .. sweep_beams()) for the sensor at `sensor` (world frame); the body of
/// robot `own_robot` (the one carrying the sensor) is transparent to its own beams.
void synthesize_sweep(const World& world, const Pose2& sensor, int angle_deg, int res_centideg, double max_range_m,
                      double range_noise_m, std::mt19937_64& rng, BeamSample* out, int own_robot = 0);

}  // namespace cairn::hil

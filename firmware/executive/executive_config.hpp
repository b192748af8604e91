// The robot executive's configuration: devices, RT loop, estimation and outputs. Shared
// by the threaded Executive (cairn-robot) and the single-threaded RobotCore it runs, which
// cairn-sim runs too. Validated by firmware/robot_config.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "common/se2.hpp"
#include "drivers/canopen/diff_drive.hpp"
#include "drivers/canopen/drive_master.hpp"
#include "drivers/modbus/power_board.hpp"
#include "drivers/sick/lms_driver.hpp"
#include "firmware/executive/features.hpp"
#include "firmware/executive/odometry.hpp"
#include "firmware/executive/protective_field.hpp"
#include "firmware/executive/rt_setup.hpp"
#include "firmware/executive/safety.hpp"
#include "firmware/localmap/local_mapper.hpp"

namespace cairn::firmware {

struct ExecutiveConfig {
  std::uint16_t robot_id = 1;
  // Tells the base a restart from a late message of the previous run (the seq counters
  // begin again): cairn-robot draws it at random once per process start; not configured.
  std::uint32_t boot_epoch = 0;
  // Devices.
  std::string lms_uri;
  lms::LmsDriverConfig lms;
  Pose2 laser_mount{0.2, 0.0, 0.0};
  std::string can_uri;
  canopen::MasterConfig master;
  canopen::DiffDriveGeometry geometry;
  std::string power_uri;
  modbus::RegisterMap power_map;
  // Every Modbus transaction's bound: two failed e-stop reads in a row stay inside the
  // 50 ms power_timeout, a slow transaction delays the next e-stop read by at most this.
  Nanos power_response_timeout = 20 * kNanosPerMilli;
  Nanos estop_poll = 5 * kNanosPerMilli;  // the fast path's cycle: e-stop + reset inputs
  Nanos power_poll = 500 * kNanosPerMilli;
  // RT loop.
  Nanos period = 10 * kNanosPerMilli;
  RtRequest rt_loop{80, -1, true};
  RtRequest io_threads{70, -1, false};
  RtRequest map_worker{50, -1, false};  // builds the next likelihood field off the RT thread
  // Estimation and outputs.
  OdometryNoise odometry;
  localmap::LocalMapConfig localmap;
  FeatureConfig features;
  int scan_publish_every = 10;
  /// Feature observations go out about once per this period (scan stamps; a scan up to
  /// min(period/4, 2 ms) early counts); 0 = every scan with features. Scans in between still
  /// correct the robot's own pose; their features are not sent (20 robots at 37.5 scans/s
  /// would be 750 base updates/s).
  Nanos feature_period = 0;
  std::size_t scan_queue = 8, odometry_queue = 256, laser_queue = 4, feature_queue = 32;
  std::size_t odometry_history = 64;  // wheel steps kept to split odometry at a scan's time (>= scan latency / period)
  SafetyLimits safety;
  ProtectiveFieldConfig field;
};

}  // namespace cairn::firmware

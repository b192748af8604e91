// The fusion's estimate of each robot's local frame over time, for the central mapper:
// a scan is inserted, and later re-rendered, at the frame of its own time
// (mapper::FrameHistory), not at the frame of the moment the map is redrawn. cairn-base's
// GridMapNode and cairn-sim's FleetSim both place scans through it. Pure: no DDS, no clock.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <vector>

#include "basestation/fusion.hpp"
#include "basestation/mapper/frame_history.hpp"
#include "basestation/mapper/mapper.hpp"
#include "common/messages.hpp"

namespace cairn::base {

class MapFrames {
 public:
  /// 65 536 frames per robot: at the 7.5 updates a second of a robot among poles, 2.4 h;
  /// a scan older than its robot's oldest frame stays where it was drawn.
  static constexpr std::size_t kDefaultFramesPerRobot = 1u << 16;
  explicit MapFrames(std::size_t frames_per_robot = kDefaultFramesPerRobot) : capacity_(frames_per_robot) {}

  /// Records the frame of every robot the fusion has localised, at its estimate's time
  /// (Fusion::estimate_clock), as of the robot's current boot.
  void record(const Fusion& fusion);
  /// One robot's; false when the fusion has no frame of its current boot (not localised,
  /// or restarted without odometry since).
  bool record(const Fusion& fusion, std::uint16_t robot);
  /// Records one robot's frame (local→global) at robot time t, of the local frame of boot
  /// `boot_epoch` that began at `boot_t0`; false if not finite.
  bool record(std::uint16_t robot, Nanos t, const Pose2& local_to_global, std::uint32_t boot_epoch = 0, Nanos boot_t0 = 0);
  /// Records the robot's frame, then inserts the scan at the frame of its time, with the
  /// other localised robots' bodies masked (their estimates now). False
  /// when the fusion has not localised the robot, or it restarted and has sent no
  /// odometry since: the scan has no place (the caller counts it).
  bool place(mapper::Mapper& map, const msg::LaserScan& scan, const Fusion& fusion);
  /// Inserts the scan at its robot's frame of its time (the first frame known for a scan
  /// older than it); false when no frame of the robot is known. `robots`: the other
  /// robots' global centres (Mapper::add_scan).
  bool place(mapper::Mapper& map, const msg::LaserScan& scan, std::span<const Vec2> robots = {}) const;
  /// Re-renders every robot's stored scans that the frames of their times moved.
  void rerender(mapper::Mapper& map) const;

  std::uint64_t frames_dropped() const;

 private:
  std::size_t capacity_;
  std::vector<Vec2> others_;  // place()'s scratch: the other robots' centres
  std::map<std::uint16_t, mapper::FrameHistory> robots_;  // the fusion's robots: bounded by its admission
};

}  // namespace cairn::base

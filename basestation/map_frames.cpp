#include "basestation/map_frames.hpp"

namespace cairn::base {

void MapFrames::record(const Fusion& fusion) {
  for (std::uint16_t id : fusion.robots()) (void)record(fusion, id);
}

bool MapFrames::record(const Fusion& fusion, std::uint16_t robot) {
  msg::PoseCorrection c;
  Fusion::EstimateClock when;
  // A robot that restarted and has sent no odometry yet: its correction is still of the
  // old local frame, and there is no new time to put it at.
  if (!fusion.correction(robot, 0, &c) || !fusion.estimate_clock(robot, &when)) return false;
  (void)record(robot, when.t, c.local_to_global, when.boot_epoch, when.boot_t0);  // a non-finite frame is not kept
  return true;
}

bool MapFrames::record(std::uint16_t robot, Nanos t, const Pose2& local_to_global, std::uint32_t boot_epoch, Nanos boot_t0) {
  return robots_.try_emplace(robot, capacity_).first->second.record(t, local_to_global, boot_epoch, boot_t0);
}

bool MapFrames::place(mapper::Mapper& map, const msg::LaserScan& scan, const Fusion& fusion) {
  // Not localised, or restarted without odometry yet (the scan's local frame may be the
  // new boot's, which the fusion has not anchored): no place for it.
  if (!record(fusion, scan.robot_id)) return false;
  others_.clear();
  msg::PoseCorrection c;
  for (std::uint16_t id : fusion.robots()) {
    if (id != scan.robot_id && fusion.correction(id, 0, &c)) others_.push_back(c.global_pose.translation());
  }
  return place(map, scan, others_);
}

bool MapFrames::place(mapper::Mapper& map, const msg::LaserScan& scan, std::span<const Vec2> robots) const {
  const auto it = robots_.find(scan.robot_id);
  if (it == robots_.end()) return false;
  const mapper::FrameHistory& h = it->second;
  std::optional<Pose2> frame = h.at(scan.stamp);
  if (!frame) frame = h.first();
  if (!frame) return false;
  (void)map.add_scan_local(scan, *frame, robots);  // refusals are the mapper's counters
  return true;
}

void MapFrames::rerender(mapper::Mapper& map) const {
  for (const auto& [id, history] : robots_) {
    (void)map.rerender(id, [&h = history](const mapper::ScanInfo& s) -> std::optional<Pose2> {
      const std::optional<Pose2> c = h.at(s.stamp);
      if (!c) return std::nullopt;
      return compose(*c, s.local_pose);
    });
  }
}

std::uint64_t MapFrames::frames_dropped() const {
  std::uint64_t n = 0;
  for (const auto& [id, h] : robots_) n += h.dropped();
  return n;
}

}  // namespace cairn::base

#include "basestation/map_frames.hpp"

namespace cairn::base {

void MapFrames::record(const Fusion& fusion) {
  for (std::uint16_t id : fusion.robots()) record(fusion, id);
}

void MapFrames::record(const Fusion& fusion, std::uint16_t robot) {
  msg::PoseCorrection c;
  if (fusion.correction(robot, 0, &c)) (void)record(robot, fusion.estimate_time(robot), c.local_to_global);
}

bool MapFrames::record(std::uint16_t robot, Nanos t, const Pose2& local_to_global) {
  return robots_.try_emplace(robot, capacity_).first->second.record(t, local_to_global);
}

bool MapFrames::place(mapper::Mapper& map, const msg::LaserScan& scan, const Fusion& fusion) {
  if (!fusion.localized(scan.robot_id)) return false;
  record(fusion, scan.robot_id);
  return place(map, scan);
}

bool MapFrames::place(mapper::Mapper& map, const msg::LaserScan& scan) const {
  const auto it = robots_.find(scan.robot_id);
  if (it == robots_.end()) return false;
  const mapper::FrameHistory& h = it->second;
  std::optional<Pose2> frame = h.at(scan.stamp);
  if (!frame) frame = h.first();
  if (!frame) return false;
  (void)map.add_scan_local(scan, *frame);  // refusals are the mapper's counters
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

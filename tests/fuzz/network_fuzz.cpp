// libFuzzer target: every network input of Cairn, as a hostile DDS peer could send it.
// Cyclone's deserializer bounds strings and arrays by the IDL, but every field value is
// the sender's: counts above capacity, NaN and infinities, bad enums, wild ids and seq.
// The input is a sequence of samples: one op byte, then the raw bytes of the IDL struct
// (zero-filled when the input runs out). Each goes through the one conversion
// (common/dds/convert) and then, as the base's node and the robot's bridge would, into
// the base's fusion (odometry, features), the base's central mapper (laser scans, placed at
// the fusion's frame of their time through base::MapFrames as basestation/grid_map_node
// does, or by a fixed frame when the robot has no place) or the robot's side (corrections, tasks, the global map's
// tiles into a small GlobalMap, classified after each) or the exploration executive (bids,
// op 7 with bit 5 set; operators' visit requests, op 7 with bit 6 set, through the
// executive's edge checks). At the
// end the fusion's state is saved and restored, and op 0xFF feeds the rest of the input to
// the state-file reader (which may refuse it with an exception, never crash).
//
// Op byte: low 3 bits select the type; bits 3-4 (+1) replace robot_id so that samples
// reach the fleet's tracks instead of being refused as unknown robots.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <sstream>
#include <vector>

#include "basestation/explore/task_allocator.hpp"
#include "basestation/explore/visit_check.hpp"
#include "basestation/fusion.hpp"
#include "basestation/map_frames.hpp"
#include "basestation/mapper/mapper.hpp"
#include "common/dds/convert.hpp"
#include "firmware/robot_bridge.hpp"

namespace {

using namespace cairn;

template <typename T>
const std::uint8_t* fill(T* out, const std::uint8_t* p, const std::uint8_t* end) {
  std::memset(static_cast<void*>(out), 0, sizeof(T));
  const std::size_t n = std::min<std::size_t>(sizeof(T), static_cast<std::size_t>(end - p));
  std::memcpy(static_cast<void*>(out), p, n);
  return p + n;
}

base::FusionConfig fleet() {
  base::FusionConfig c;
  base::RobotPrior a;
  a.known = true;
  a.sigma = Vec3(0.05, 0.05, 0.02);
  c.robots[1] = a;
  a.pose = {2.0, 1.0, 0.5};
  c.robots[2] = a;
  c.allow_unknown_robots = true;  // robots 3 and 4 join as unknown ones
  c.max_unknown_robots = 1;
  c.max_landmarks = 64;
  return c;
}

mapper::MapperConfig small_grid() {
  mapper::MapperConfig c;
  c.origin_x = c.origin_y = -10;
  c.width_m = c.height_m = 20;
  c.store_bytes = 64 * 1024;  // small: the full-store path is reached
  return c;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  base::Fusion fusion(fleet());
  mapper::Mapper map(small_grid());
  base::MapFrames frames;
  firmware::GlobalMapConfig robot_map_cfg;
  robot_map_cfg.max_cells = 6 * 64 * 64;  // small: the out-of-room paths are reached
  firmware::GlobalMap robot_map(robot_map_cfg);
  ClassGrid robot_classes;
  explore::AllocatorConfig allocator_cfg;
  allocator_cfg.bid_wait = 0;
  explore::TaskAllocator allocator(allocator_cfg);
  std::vector<msg::TaskAssignment> assignments;
  Nanos now = 0;
  const std::uint8_t* p = data;
  const std::uint8_t* end = data + size;
  while (p < end) {
    const std::uint8_t op = *p++;
    const auto robot = static_cast<std::uint16_t>(((op >> 3) & 3) + 1);
    if (op == 0xFF) {  // the persisted state file
      base::Fusion restored(fleet());
      std::istringstream in(std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(end - p)));
      try {
        restored.load(in);
      } catch (const std::exception&) {
      }
      break;
    }
    switch (op & 7) {
      case 0: {
        cairn_OdometryIncrement d;
        p = fill(&d, p, end);
        d.robot_id = robot;
        msg::OdometryIncrement m;
        (void)dds::from_dds(d, &m);  // the node refuses a clamped sample; the fusion must survive it anyway
        (void)fusion.on_odometry(m);
        break;
      }
      case 1: {
        cairn_FeatureObservations d;
        p = fill(&d, p, end);
        d.robot_id = robot;
        msg::FeatureObservations m;
        (void)dds::from_dds(d, &m);
        (void)fusion.on_features(m);
        break;
      }
      case 2: {
        cairn_PoseCorrection d;
        p = fill(&d, p, end);
        msg::PoseCorrection m;
        (void)dds::from_dds(d, &m);
        break;
      }
      case 3: {
        cairn_TaskAssignment d;
        p = fill(&d, p, end);
        msg::TaskAssignment m;
        (void)dds::from_dds(d, &m);
        break;
      }
      case 4: {
        cairn_LaserScan d;
        p = fill(&d, p, end);
        msg::LaserScan m;
        if (!dds::from_dds(d, &m)) break;
        if (!frames.place(map, m, fusion)) (void)map.add_scan_local(m, {0.5, -0.25, 0.1});
        break;
      }
      case 5: {
        cairn_SafetyReset d;
        p = fill(&d, p, end);
        msg::SafetyReset m;
        (void)dds::from_dds(d, &m);
        cairn_SafetyStop ds;
        p = fill(&ds, p, end);
        msg::SafetyStop ms;
        (void)dds::from_dds(ds, &ms);
        break;
      }
      case 6: {  // the base's global map, as the robot's bridge keeps it
        static cairn_MapTile d;  // 4 KiB: not on the fuzzer's stack
        p = fill(&d, p, end);
        if (d.robot_id == 0) (void)robot_map.apply(firmware::map_tile_view(d));
        (void)robot_map.classify(&robot_classes);
        break;
      }
      case 7:
        if (op & 0x20) {  // a robot's bid, into the exploration executive
          static cairn_Bid d;
          p = fill(&d, p, end);
          msg::Bid m;
          (void)dds::from_dds(d, &m);
          (void)allocator.on_bid(m, now);
          allocator.on_robot_pose(robot, Vec2(1.0, 0.5), now);
          now += 100 * kNanosPerMilli;
          assignments.clear();
          (void)allocator.tick(now, &assignments);
          break;
        }
        if (op & 0x40) {  // an operator's visit request, as ExploreNode takes it
          cairn_VisitRequest d;
          p = fill(&d, p, end);
          msg::VisitRequest m;
          (void)dds::from_dds(d, &m);
          const bool localised = m.robot_id == robot;  // the fuzzer decides which robots the fusion knows
          if (base::check_visit(m, localised) == base::VisitVerdict::kAccepted) {
            (void)allocator.request_visit(m.robot_id, Vec2(m.x, m.y), now);
          }
          now += 100 * kNanosPerMilli;
          assignments.clear();
          (void)allocator.tick(now, &assignments);
          break;
        }
        [[fallthrough]];
      default: {  // what the node publishes: corrections and the landmark map
        msg::PoseCorrection c;
        (void)fusion.correction(robot, 0, &c);
        std::vector<msg::Landmark> landmarks;
        fusion.landmarks(&landmarks);
        frames.record(fusion);
        frames.rerender(map);
        (void)map.take_changed();
        break;
      }
    }
  }
  // Whatever was accepted can be saved and restored.
  std::stringstream state;
  fusion.save(state);
  base::Fusion restored(fleet());
  restored.load(state);
  return 0;
}

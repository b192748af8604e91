#include "firmware/robot_config.hpp"

#include <cmath>

#include "common/config.hpp"
#include "drivers/modbus/power_config.hpp"
#include "firmware/localmap/work_estimate.hpp"

namespace cairn::firmware {
namespace {

Nanos seconds_key(const ConfigSection& s, const char* key, Nanos fallback, Range<double> range) {
  return seconds_to_nanos(s.number_or(key, nanos_to_seconds(fallback), range));
}

void read_devices(const ConfigSection& d, ExecutiveConfig* e) {
  e->lms_uri = d.string("lms");
  const auto baud = d.integer_or("lms_baud", e->lms.target_baud, {9600, 500000});
  if (!lms::valid_baud(static_cast<std::uint32_t>(baud))) {
    std::string rates;
    for (std::uint32_t b : lms::kBauds) rates += (rates.empty() ? "" : ", ") + std::to_string(b);
    d.fail("lms_baud", "expected one of " + rates + " (the LMS2xx's rates), got " + std::to_string(baud));
  }
  e->lms.target_baud = static_cast<std::uint32_t>(baud);
  e->lms.angle_deg = static_cast<std::uint16_t>(d.integer_or("lms_angle_deg", e->lms.angle_deg, {100, 180}));
  if (e->lms.angle_deg != 100 && e->lms.angle_deg != 180) d.fail("lms_angle_deg", "expected 100 or 180");
  const double res = d.number_or("lms_resolution_deg", e->lms.resolution_centideg / 100.0, {0.25, 1.0});
  const int centi = static_cast<int>(std::lround(res * 100));
  if (centi != 25 && centi != 50 && centi != 100) d.fail("lms_resolution_deg", "expected 1, 0.5 or 0.25");
  if (!lms::valid_variant(e->lms.angle_deg, static_cast<std::uint16_t>(centi))) {
    d.fail("lms_resolution_deg", "0.25 deg needs lms_angle_deg = 100");  // the one variant the angle check leaves
  }
  e->lms.resolution_centideg = static_cast<std::uint16_t>(centi);
  e->can_uri = d.string("can");
  if (d.has("drive_nodes")) {
    const auto nodes = d.numbers("drive_nodes", 2, 2);
    for (double n : nodes) {
      if (n != std::floor(n) || n < 1 || n > 127) d.fail("drive_nodes", "expected two CANopen node ids in [1, 127]");
    }
    if (nodes[0] == nodes[1]) d.fail("drive_nodes", "the left and right drives need different node ids");
    e->master.nodes = {static_cast<std::uint8_t>(nodes[0]), static_cast<std::uint8_t>(nodes[1]), 0, 0};
  }
  e->power_uri = d.string("power");
}

void read_pose3(const ConfigSection& s, const char* key, Pose2* out) {
  if (!s.has(key)) return;
  const auto v = s.numbers(key, 3, 3);
  *out = {v[0], v[1], v[2]};
}

void read_geometry(const ConfigSection& g, canopen::DiffDriveGeometry* geo) {
  geo->wheel_radius_m = g.number_or("wheel_radius_m", geo->wheel_radius_m, {0.01, 2.0});
  geo->track_m = g.number_or("track_m", geo->track_m, {0.05, 5.0});
  geo->gear_ratio = g.number_or("gear_ratio", geo->gear_ratio, {0.01, 1000.0});
  geo->encoder_counts_per_rev = g.number_or("encoder_counts_per_rev", geo->encoder_counts_per_rev, {1.0, 1e7});
  geo->right_inverted = g.boolean_or("right_inverted", geo->right_inverted);
}

void read_rt(const ConfigSection& r, RobotConfig* c) {
  ExecutiveConfig& e = c->executive;
  e.period = seconds_key(r, "period_s", e.period, {0.001, 0.1});
  e.master.sync_period = e.period;  // the drives are commanded once per RT cycle
  e.rt_loop.priority = static_cast<int>(r.integer_or("priority", e.rt_loop.priority, {0, 99}));
  e.io_threads.priority = static_cast<int>(r.integer_or("io_priority", e.io_threads.priority, {0, 99}));
  e.map_worker.priority = static_cast<int>(r.integer_or("map_worker_priority", e.map_worker.priority, {0, 99}));
  e.rt_loop.cpu = static_cast<int>(r.integer_or("cpu", e.rt_loop.cpu, {-1, 1023}));
  e.rt_loop.lock_memory = r.boolean_or("lock_memory", e.rt_loop.lock_memory);
  c->bridge_period = seconds_key(r, "bridge_period_s", c->bridge_period, {0.0005, 0.1});
}

void read_field(const ConfigSection& s, ProtectiveFieldConfig* f) {
  f->enabled = s.boolean_or("field", f->enabled);
  f->radius_m = s.number_or("field_radius_m", f->radius_m, {0.05, 5.0});
  f->side_margin_m = s.number_or("field_side_margin_m", f->side_margin_m, {0.0, 1.0});
  f->front_margin_m = s.number_or("field_front_margin_m", f->front_margin_m, {0.0, 2.0});
  f->reaction_s = s.number_or("field_reaction_s", f->reaction_s, {0.0, 2.0});
  f->reverse_max_v = s.number_or("reverse_max_v", f->reverse_max_v, {0.0, 5.0});
  f->restart_m = s.number_or("field_restart_m", f->restart_m, {0.0, 1.0});
}

void read_safety(const ConfigSection& s, SafetyLimits* l) {
  l->max_v = s.number_or("max_v", l->max_v, {0.0, 5.0});
  l->max_w = s.number_or("max_w", l->max_w, {0.0, 10.0});
  l->max_acc = s.number_or("max_acc", l->max_acc, {0.01, 20.0});
  l->max_alpha = s.number_or("max_alpha", l->max_alpha, {0.01, 50.0});
  l->link_timeout = seconds_key(s, "link_timeout_s", l->link_timeout, {0.0, 600.0});
  l->laser_timeout = seconds_key(s, "laser_timeout_s", l->laser_timeout, {0.05, 60.0});
  l->command_timeout = seconds_key(s, "command_timeout_s", l->command_timeout, {0.05, 60.0});
  // The e-stop input and the wheel feedback: a stale one stops within <= 100 ms (docs/firmware.md).
  l->power_timeout = seconds_key(s, "power_timeout_s", l->power_timeout, {0.02, 0.1});
  l->feedback_timeout = seconds_key(s, "feedback_timeout_s", l->feedback_timeout, {0.02, 0.1});
}

void read_mapping(const ConfigSection& m, ExecutiveConfig* e) {
  e->scan_publish_every = static_cast<int>(m.integer_or("scan_publish_every", e->scan_publish_every, {1, 1000}));
  e->feature_period = seconds_key(m, "feature_period_s", e->feature_period, {0.0, 10.0});
  e->localmap.keyframes = static_cast<int>(m.integer_or("keyframes", e->localmap.keyframes, {1, 100}));
  e->localmap.grid.size_cells = static_cast<int>(m.integer_or("grid_cells", e->localmap.grid.size_cells, {64, 4096}));
  e->localmap.grid.resolution_m = m.number_or("grid_resolution_m", e->localmap.grid.resolution_m, {0.01, 0.5});
  e->localmap.max_range_m = m.number_or("max_range_m", e->localmap.max_range_m, {0.5, 80.0});
  e->localmap.map_relative_drift = m.boolean_or("map_relative_drift", e->localmap.map_relative_drift);
  if (const char* why = localmap::validate(e->localmap)) m.fail("keyframes", std::string("local map: ") + why);
}

// The local map's worst-case work must fit: matching in half the RT period, the keyframe
// rebuild (the rebuild worker's) in half the shortest time between keyframes at the
// safety limits. The model: firmware/localmap/work_estimate.hpp, docs/localmap.md.
void check_localmap_budget(const ConfigSection& root, const ExecutiveConfig& e) {
  const int beams = e.lms.angle_deg * 100 / e.lms.resolution_centideg + 1;
  localmap::WorkBudget b;
  b.rt_period_s = nanos_to_seconds(e.period);
  b.keyframe_interval_s = localmap::min_keyframe_interval_s(e.localmap, e.safety.max_v, e.safety.max_w);
  const std::string why = localmap::check_budget(e.localmap, beams, b);
  if (!why.empty()) root.fail("mapping", "local map: " + why);
}

void read_nav_monitor(const ConfigSection& m, NavMonitorConfig* n) {
  n->stuck_after = seconds_key(m, "stuck_after_s", n->stuck_after, {0.5, 600.0});
  n->progress_m = m.number_or("progress_m", n->progress_m, {0.01, 10.0});
}

void read_motion(const ConfigSection& m, MotionConfig* motion) {
  motion->follower.speed = m.number_or("speed", motion->follower.speed, {0.0, 5.0});
  motion->follower.loop = m.boolean_or("loop", motion->follower.loop);
  auto& f = motion->follower;
  f.lookahead_time_s = m.number_or("lookahead_time_s", f.lookahead_time_s, {0.0, 10.0});
  f.lookahead_min = m.number_or("lookahead_min", f.lookahead_min, {0.05, 10.0});
  f.lookahead_max = m.number_or("lookahead_max", f.lookahead_max, {0.05, 10.0});
  if (const std::string why = f.check(); !why.empty()) m.fail("lookahead_max", why);
  if (!m.has("waypoints")) return;
  const auto v = m.numbers("waypoints", 2, 2 * 256);
  if (v.size() % 2) m.fail("waypoints", "expected a flat list of x, y pairs (m, local frame), got an odd count");
  for (std::size_t i = 0; i + 1 < v.size(); i += 2) motion->waypoints.emplace_back(v[i], v[i + 1]);
}

void read_map(const ConfigSection& m, GlobalMapConfig* g) {
  g->max_cells = static_cast<std::size_t>(
      m.integer_or("max_cells", static_cast<std::int64_t>(g->max_cells), {4096, std::int64_t{1} << 22}));
  g->p_o = m.number_or("p_o", g->p_o, {0.0, 1.0});
  g->p_c = m.number_or("p_c", g->p_c, {0.0, 1.0});
  if (!(g->p_c < g->p_o)) m.fail("p_c", "must be below p_o (" + std::to_string(g->p_o) + ")");
}

void read_explore(const ConfigSection& e, RobotExploreConfig* x) {
  x->enabled = e.boolean_or("enabled", x->enabled);
  x->bid_period = seconds_key(e, "bid_period_s", x->bid_period, {0.1, 600.0});
  const double radius = e.number_or("robot_radius_m", x->bidder.robot_radius_m, {0.05, 5.0});
  x->bidder.robot_radius_m = x->planner.robot_radius_m = radius;
  x->bidder.sensor_range_m = e.number_or("sensor_range_m", x->bidder.sensor_range_m, {0.5, 80.0});
  x->bidder.frontier_spacing_m = e.number_or("frontier_spacing_m", x->bidder.frontier_spacing_m, {0.01, 10.0});
  x->bidder.gain_per_metre = e.number_or("gain_per_metre", x->bidder.gain_per_metre, {0.0, 1e6});
  x->bidder.wall_gap_m = e.number_or("wall_gap_m", x->bidder.wall_gap_m, {0.0, 1.0});
  if (e.has("area_m")) {  // [min_x, min_y, max_x, max_y], global frame
    const std::vector<double> a = e.numbers("area_m", 4, 4);
    if (!(a[0] < a[2] && a[1] < a[3])) e.fail("area_m", "must be [min_x, min_y, max_x, max_y] with min < max");
    x->bidder.has_area = true;
    x->bidder.area_min_x = a[0], x->bidder.area_min_y = a[1], x->bidder.area_max_x = a[2], x->bidder.area_max_y = a[3];
  }
  x->blocks.replan_after = seconds_key(e, "blocked_replan_after_s", x->blocks.replan_after, {0.1, 60.0});
  x->blocks.memory = seconds_key(e, "blocked_memory_s", x->blocks.memory, {0.0, 3600.0});
  x->blocks.keep_right_m = e.number_or("blocked_keep_right_m", x->blocks.keep_right_m, {0.0, 5.0});
  x->blocks.keep_right_memory =
      seconds_key(e, "blocked_keep_right_s", x->blocks.keep_right_memory, {0.0, 3600.0});
}

RobotConfig read(const ConfigDocument& doc) {
  const ConfigSection root = doc.root();
  RobotConfig c;
  const ConfigSection robot = root.section("robot");
  c.id = static_cast<std::uint16_t>(robot.integer("id", {1, 250}));
  c.name = robot.string_or("name", "robot-" + std::to_string(c.id));
  c.dds = dds::profile_from_config(root.optional_section("dds"));
  if (const auto status = root.optional_section("status")) {
    c.status_period = seconds_to_nanos(status->number_or("period_s", 1.0, {0.01, 60.0}));
    c.liveliness_lease = seconds_to_nanos(status->number_or("liveliness_lease_s", 1.5, {0.1, 60.0}));
  }
  if (const auto d = root.optional_section("devices")) {
    c.has_devices = true;
    read_devices(*d, &c.executive);
  }
  if (const auto p = root.optional_section("power")) c.executive.power_map = modbus::register_map_from_config(*p);
  if (const auto l = root.optional_section("laser")) read_pose3(*l, "mount", &c.executive.laser_mount);
  if (const auto g = root.optional_section("geometry")) read_geometry(*g, &c.executive.geometry);
  if (const auto r = root.optional_section("rt")) read_rt(*r, &c);
  if (const auto s = root.optional_section("safety")) {
    read_safety(*s, &c.executive.safety);
    read_field(*s, &c.executive.field);
  }
  if (const auto m = root.optional_section("mapping")) read_mapping(*m, &c.executive);
  if (const auto m = root.optional_section("motion")) {
    read_motion(*m, &c.motion);
    read_nav_monitor(*m, &c.nav_monitor);
  }
  if (const auto m = root.optional_section("map")) read_map(*m, &c.global_map);
  if (const auto e = root.optional_section("explore")) read_explore(*e, &c.explore);
  if (c.has_devices) {
    check_localmap_budget(root, c.executive);
    const ExecutiveConfig& e = c.executive;
    const std::string why = e.field.check(e.safety.max_v, e.safety.max_acc, e.localmap.max_range_m);
    if (!why.empty()) root.fail("safety", why);
  }
  c.motion.follower.max_w = std::min(c.motion.follower.max_w, c.executive.safety.max_w);
  doc.finish();
  c.executive.robot_id = c.id;
  return c;
}

}  // namespace

RobotConfig load_robot_config(const std::string& path) { return read(ConfigDocument::load(path)); }

RobotConfig parse_robot_config(const std::string& text, const std::string& name) {
  return read(ConfigDocument::parse(text, name));
}

}  // namespace cairn::firmware

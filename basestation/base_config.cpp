#include "basestation/base_config.hpp"

#include <arpa/inet.h>

#include "common/config.hpp"

namespace cairn::base {

namespace {

bool is_ip_literal(const std::string& s) {
  unsigned char buf[16];
  return inet_pton(AF_INET, s.c_str(), buf) == 1 || inet_pton(AF_INET6, s.c_str(), buf) == 1;
}

void read_web(const ConfigSection& w, WebConfig* c) {
  c->enabled = w.boolean_or("enabled", false);
  c->listen = w.string_or("listen", c->listen);
  if (!is_ip_literal(c->listen)) w.fail("listen", "expected an IPv4 or IPv6 address such as 127.0.0.1 (no host names)");
  c->port = static_cast<std::uint16_t>(w.integer_or("port", c->port, {0, 65535}));
  c->token = w.string_or("token", "");
  c->state_period = seconds_to_nanos(w.number_or("state_period_s", 0.2, {0.02, 60.0}));
  c->map_period = seconds_to_nanos(w.number_or("map_period_s", 2.0, {0.2, 600.0}));
  if (c->enabled && c->token.size() < kMinWebTokenLength) {
    w.fail("token", "the web view needs a token of at least " + std::to_string(kMinWebTokenLength) +
                        " characters (e.g. `od -An -tx1 -N16 /dev/urandom | tr -d ' \\n'`)");
  }
  // It travels in a URL's query: only characters no browser escapes there.
  for (const char ch : c->token) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '-' ||
                    ch == '_' || ch == '.' || ch == '~';
    if (!ok) w.fail("token", "use only letters, digits and - _ . ~ (it travels in a URL)");
  }
}

BaseConfig from_document(const ConfigDocument& doc) {
  const ConfigSection root = doc.root();
  BaseConfig c;
  if (const auto b = root.optional_section("base")) c.name = b->string_or("name", "base");
  c.dds = dds::profile_from_config(root.optional_section("dds"));
  if (const auto f = root.optional_section("fleet")) {
    c.stale_after = seconds_to_nanos(f->number_or("stale_after_s", 3.0, {0.1, 3600.0}));
    c.table_period = seconds_to_nanos(f->number_or("table_period_s", 1.0, {0.1, 3600.0}));
  }
  if (const auto f = root.optional_section("fusion")) {
    c.fusion_enabled = f->boolean_or("enabled", true);
    c.state_dir = f->string_or("state_dir", c.state_dir);
    c.snapshot_period = seconds_to_nanos(f->number_or("snapshot_period_s", 30.0, {0.1, 86400.0}));
    c.correction_period = seconds_to_nanos(f->number_or("correction_period_s", 0.2, {0.01, 60.0}));
    c.map_period = seconds_to_nanos(f->number_or("map_period_s", 1.0, {0.05, 600.0}));
    c.history_depth = static_cast<int>(f->integer_or("history_depth", 512, {1, 100000}));
    c.fusion.iterations = static_cast<int>(f->integer_or("update_iterations", 1, {1, 50}));
    c.fusion.candidate_range = f->number_or("candidate_range_m", 15.0, {0.5, 1000.0});
    c.fusion.robot_observations = f->boolean_or("robot_observations", true);
    FusionConfig& u = c.fusion;
    u.max_landmarks = static_cast<std::size_t>(f->integer_or("max_landmarks", 2000, {1, 100000}));
    u.landmark_confirm_count = static_cast<std::uint32_t>(f->integer_or("landmark_confirm_count", 3, {1, 1000}));
    u.landmark_confirm_age = static_cast<std::uint64_t>(f->integer_or("landmark_confirm_age", 100, {1, 1000000}));
    u.jcbb.relocation_margin = static_cast<int>(f->integer_or("relocation_margin", 1, {0, 32}));
    FusionLimits& l = u.limits;
    l.max_step_m = f->number_or("max_step_m", l.max_step_m, {0.01, 1000.0});
    l.max_step_rad = f->number_or("max_step_rad", l.max_step_rad, {0.01, 10.0});
    l.max_coordinate_m = f->number_or("max_coordinate_m", l.max_coordinate_m, {1.0, 1e7});
    l.max_variance = f->number_or("max_variance", l.max_variance, {1e-6, 1e8});
    l.max_range_m = f->number_or("max_range_m", l.max_range_m, {0.1, 10000.0});
    l.max_seq_gap = static_cast<std::uint32_t>(f->integer_or("max_seq_gap", l.max_seq_gap, {1, 100000000}));
    l.innovation_confidence = f->number_or("innovation_confidence", l.innovation_confidence, {0.9, 0.999999999});
  }
  auto read_sigma = [](const ConfigSection& s, const char* key, Vec3 fallback) {
    if (!s.has(key)) return fallback;
    const auto v = s.numbers(key, 3, 3);
    for (double x : v) {
      if (x <= 0) s.fail(key, "expected three positive standard deviations [x m, y m, theta rad]");
    }
    return Vec3(v[0], v[1], v[2]);
  };
  if (root.has("robot")) {
    for (const ConfigSection& r : root.sections("robot")) {
      const auto id = static_cast<std::uint16_t>(r.integer("id", {1, 250}));
      RobotPrior p;
      p.known = r.has("initial_pose");
      if (p.known) {
        const auto v = r.numbers("initial_pose", 3, 3);
        p.pose = {v[0], v[1], v[2]};
      }
      p.sigma = read_sigma(r, "initial_sigma", p.known ? Vec3(0.05, 0.05, 0.02) : Vec3(100, 100, 3.0));
      if (c.fusion.robots.count(id)) r.fail("id", "robot " + std::to_string(id) + " is listed twice");
      c.fusion.robots[id] = p;
    }
  }
  if (const auto m = root.optional_section("mapper")) {
    c.mapper_enabled = m->boolean_or("enabled", true);
    c.mapper = mapper::mapper_config_from(*m);
    c.map_tile_period = seconds_to_nanos(m->number_or("tile_period_s", 1.0, {0.05, 600.0}));
    c.map_reframe_period = seconds_to_nanos(m->number_or("reframe_period_s", 10.0, {0.1, 3600.0}));
    c.map_export_dir = m->string_or("export_dir", c.map_export_dir);
  }
  if (const auto e = root.optional_section("explore")) {
    c.explore_enabled = e->boolean_or("enabled", false);
    explore::AllocatorConfig& a = c.explore;
    a.bid_wait = seconds_to_nanos(e->number_or("bid_wait_s", nanos_to_seconds(a.bid_wait), {0.0, 60.0}));
    a.cells_per_metre = e->number_or("cells_per_metre", a.cells_per_metre, {0.0, 1e6});
    a.min_gain = e->number_or("min_gain", a.min_gain, {0.0, 1e9});
    a.hysteresis_ratio = e->number_or("hysteresis_ratio", a.hysteresis_ratio, {0.01, 1.0});
    a.no_progress_timeout =
        seconds_to_nanos(e->number_or("no_progress_timeout_s", nanos_to_seconds(a.no_progress_timeout), {0.5, 3600.0}));
    a.bar_duration = seconds_to_nanos(e->number_or("bar_s", nanos_to_seconds(a.bar_duration), {0.0, 86400.0}));
    a.arrival_radius_m = e->number_or("arrival_radius_m", a.arrival_radius_m, {0.01, 10.0});
    a.look_radius_m = e->number_or("look_radius_m", a.look_radius_m, {0.01, 20.0});
    a.give_up_attempts = static_cast<std::uint32_t>(e->integer_or("give_up_attempts", a.give_up_attempts, {0, 1000}));
    a.coordinated = e->boolean_or("coordinated", a.coordinated);
    // At the end, every listed robot with a known start pose drives back to it.
    if (e->boolean_or("return_home", true)) {
      for (const auto& [id, prior] : c.fusion.robots) {
        if (prior.known) a.home[id] = Vec2(prior.pose.x, prior.pose.y);
      }
    }
    try {
      explore::validate(a);
    } catch (const std::invalid_argument& ex) {
      e->fail("enabled", ex.what());
    }
    if (c.explore_enabled && !c.fusion_enabled) e->fail("enabled", "exploration needs [fusion] enabled = true");
  }
  if (const auto w = root.optional_section("web")) read_web(*w, &c.web);
  if (const auto f = root.optional_section("fusion")) c.fusion.restart_sigma = read_sigma(*f, "restart_sigma", c.fusion.restart_sigma);
  if (const auto u = root.optional_section("unknown_robot")) {
    c.fusion.unknown.sigma = read_sigma(*u, "initial_sigma", c.fusion.unknown.sigma);
    c.fusion.allow_unknown_robots = u->boolean_or("allow", false);
    c.fusion.max_unknown_robots = static_cast<std::size_t>(u->integer_or("max_robots", 8, {0, 1000}));
  }
  // The map frame is defined by configuration: a listed robot with a known start pose.
  // Without one, fusion would have no frame (and must not take whoever speaks first).
  if (c.fusion_enabled) {
    bool frame = false;
    for (const auto& [id, p] : c.fusion.robots) frame = frame || p.known;
    if (!frame) {
      throw ConfigError(doc.name() + ": [fusion] is enabled but no [[robot]] has an initial_pose: one listed robot "
                        "with a known start pose defines the map frame");
    }
  }
  doc.finish();
  return c;
}

}  // namespace

BaseConfig load_base_config(const std::string& path) { return from_document(ConfigDocument::load(path)); }

BaseConfig parse_base_config(std::string_view text, const std::string& name) {
  return from_document(ConfigDocument::parse(text, name));
}

}  // namespace cairn::base

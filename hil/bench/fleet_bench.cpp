#include "hil/bench/fleet_bench.hpp"

#include <toml++/toml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace cairn::hil {

const char* fault_name(FaultKind k) {
  switch (k) {
    case FaultKind::kEstop: return "estop";
    case FaultKind::kLaserUnplug: return "laser";
    case FaultKind::kDriveSilent: return "drive";
    case FaultKind::kPowerSilent: return "power";
  }
  return "?";
}

ScheduledFault ScheduledFault::parse(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  for (std::string p; std::getline(ss, p, ':');) parts.push_back(p);
  const std::string form = "expected T:ROBOT:KIND[:DURATION] (e.g. 20:1:estop:2; kinds estop, laser, drive, power), got '" + text + "'";
  if (parts.size() < 3 || parts.size() > 4) throw std::invalid_argument(form);
  ScheduledFault f;
  try {
    std::size_t used = 0;
    f.at_s = std::stod(parts[0], &used);
    if (used != parts[0].size() || !(f.at_s >= 0)) throw std::invalid_argument(form);
    f.robot = std::stoi(parts[1], &used);
    if (used != parts[1].size() || f.robot < 1) throw std::invalid_argument(form);
    if (parts.size() == 4) {
      f.duration_s = std::stod(parts[3], &used);
      if (used != parts[3].size() || !(f.duration_s > 0)) throw std::invalid_argument(form);
    }
  } catch (const std::logic_error&) {
    throw std::invalid_argument(form);
  }
  bool known = false;
  for (FaultKind k : {FaultKind::kEstop, FaultKind::kLaserUnplug, FaultKind::kDriveSilent, FaultKind::kPowerSilent}) {
    if (parts[2] == fault_name(k)) f.kind = k, known = true;
  }
  if (!known) throw std::invalid_argument(form);
  return f;
}

FleetBench::FleetBench(const World& world, const FleetBenchConfig& cfg) : world_(world), cfg_(cfg) {
  if (cfg.robots.empty()) throw std::runtime_error("HIL fleet: no robots");
  if ((!cfg.can_iface.empty() || !cfg.lms_uart.empty()) && cfg.robots.size() != 1) {
    throw std::runtime_error("HIL fleet: a SocketCAN interface or a UART serves one robot, not " + std::to_string(cfg.robots.size()));
  }
  if (cfg.lms_uart.empty() != cfg.lms_host_uri.empty()) {
    throw std::runtime_error("HIL fleet: a laser UART needs the URI of its other end, and only then (--lms-uart with --lms-host-uri)");
  }
  std::vector<RobotBenchConfig> configs;
  for (int id : cfg.robots) {
    const auto start = world.start(id);
    if (!start) throw std::runtime_error("HIL fleet: world " + world.name() + " has no 'start " + std::to_string(id) + " X Y THETA' line");
    RobotBenchConfig& bc = configs.emplace_back();
    bc.robot_id = id;
    bc.start = *start;
    bc.lms_tcp = cfg.lms_tcp;
    bc.can_iface = cfg.can_iface;
    bc.lms_uart = cfg.lms_uart;
    bc.lms_host_uri = cfg.lms_host_uri;
    bc.lms_uart_baud = cfg.lms_uart_baud;
  }
  if (cfg.shared_world) {
    std::vector<Body> bodies;
    for (const RobotBenchConfig& bc : configs) bodies.push_back({bc.robot_id, bc.start, bc.body_radius});
    bodies_ = std::make_unique<FleetBodies>(std::move(bodies));  // throws for a repeated id
    contacts_seen_.assign(configs.size() * configs.size(), 0);
  }
  for (const RobotBenchConfig& bc : configs) benches_.push_back(std::make_unique<RobotBench>(world, bc, bodies_.get()));
  for (const ScheduledFault& f : cfg.faults) {
    bool found = false;
    for (int id : cfg.robots) found = found || id == f.robot;
    if (!found) throw std::runtime_error("HIL fleet: a fault names robot " + std::to_string(f.robot) + ", which is not on the bench");
  }
  fault_state_.assign(cfg.faults.size(), 0);
}

FleetBench::~FleetBench() { stop(); }

void FleetBench::start() {
  for (auto& b : benches_) b->start();
}

void FleetBench::stop() {
  for (auto& b : benches_) b->stop();
}

std::vector<Vec2> FleetBench::local_route(std::size_t i) const {
  const Pose2 start = *world_.start(cfg_.robots[i]);
  std::vector<Vec2> out;
  for (const Vec2& p : world_.route(cfg_.robots[i])) out.push_back(inverse_transform_point(start, p));
  return out;
}

std::vector<std::string> FleetBench::write_robot_configs() const {
  toml::table tmpl;
  try {
    tmpl = toml::parse_file(cfg_.robot_template);
  } catch (const toml::parse_error& e) {
    throw std::runtime_error("HIL fleet: robot template " + cfg_.robot_template + ": " + std::string(e.description()));
  }
  std::filesystem::create_directories(cfg_.out_dir);
  std::vector<std::string> paths;
  for (std::size_t i = 0; i < benches_.size(); ++i) {
    toml::table t = tmpl;
    const int id = cfg_.robots[i];
    auto section = [&](const char* name) -> toml::table& {
      if (!t.contains(name)) t.insert(name, toml::table{});
      return *t[name].as_table();
    };
    section("robot").insert_or_assign("id", id);
    section("robot").insert_or_assign("name", "robot-" + std::to_string(id));
    toml::table& dev = section("devices");
    dev.insert_or_assign("lms", benches_[i]->lms_uri());
    dev.insert_or_assign("can", benches_[i]->can_uri());
    dev.insert_or_assign("power", benches_[i]->power_uri());
    if (!cfg_.lms_uart.empty()) dev.insert_or_assign("lms_baud", static_cast<std::int64_t>(cfg_.lms_uart_baud));
    const auto route = local_route(i);
    if (!route.empty()) {
      toml::array wp;
      for (const Vec2& p : route) {
        wp.push_back(std::round(p.x() * 1000) / 1000);
        wp.push_back(std::round(p.y() * 1000) / 1000);
      }
      section("motion").insert_or_assign("waypoints", wp);
    }
    const std::string path = (std::filesystem::path(cfg_.out_dir) / ("robot-" + std::to_string(id) + ".toml")).string();
    std::ofstream out(path);
    out << "# Written by cairn-hil from " << cfg_.robot_template << " for robot " << id << " on world " << world_.name()
        << ".\n# The device URIs point at this bench's emulators; the route is in the robot's local frame.\n\n"
        << toml::toml_formatter(t, toml::toml_formatter::default_flags | toml::format_flags::relaxed_float_precision) << "\n";
    if (!out) throw std::runtime_error("HIL fleet: cannot write " + path);
    paths.push_back(path);
  }
  return paths;
}

void FleetBench::set_fault(const ScheduledFault& f, bool on) {
  for (std::size_t i = 0; i < benches_.size(); ++i) {
    if (cfg_.robots[i] != f.robot) continue;
    RobotBench& b = *benches_[i];
    switch (f.kind) {
      case FaultKind::kEstop: b.power().press_estop(on); break;
      case FaultKind::kLaserUnplug: b.lms().unplug(on); break;
      case FaultKind::kDriveSilent: b.drive(1).with_node([on](DriveNode& n) { return (n.set_silent(on), 0); }); break;
      case FaultKind::kPowerSilent: b.power().set_silent(on); break;
    }
  }
}

std::vector<std::string> FleetBench::apply_faults(double t_s) {
  std::vector<std::string> lines;
  for (std::size_t i = 0; i < cfg_.faults.size(); ++i) {
    const ScheduledFault& f = cfg_.faults[i];
    char buf[128];
    if (fault_state_[i] == 0 && t_s >= f.at_s) {
      set_fault(f, true);
      fault_state_[i] = 1;
      std::snprintf(buf, sizeof buf, "fault on: robot %d %s for %.1f s", f.robot, fault_name(f.kind), f.duration_s);
      lines.emplace_back(buf);
    } else if (fault_state_[i] == 1 && t_s >= f.at_s + f.duration_s) {
      set_fault(f, false);
      fault_state_[i] = 2;
      std::snprintf(buf, sizeof buf, "fault off: robot %d %s", f.robot, fault_name(f.kind));
      lines.emplace_back(buf);
    }
  }
  return lines;
}

void FleetBench::write_truth(std::FILE* out, double t_s) const {
  for (std::size_t i = 0; i < benches_.size(); ++i) {
    const TruthSample s = benches_[i]->truth();
    std::fprintf(out, "%.3f %d %.4f %.4f %.5f %.3f\n", t_s, cfg_.robots[i], s.pose.x, s.pose.y, s.pose.theta, s.odometer);
  }
}

template <class F>
void FleetBench::for_each_pair(F&& f) const {
  const std::size_t n = cfg_.robots.size();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const int a = cfg_.robots[i], b = cfg_.robots[j];
      f(i * n + j, RobotContacts{a, b, bodies_->contacts(a, b), bodies_->refused_moves(a, b)});
    }
  }
}

std::vector<RobotContacts> FleetBench::new_contacts() {
  std::vector<RobotContacts> out;
  if (!bodies_) return out;
  for_each_pair([&](std::size_t k, const RobotContacts& c) {
    if (c.contacts != contacts_seen_[k]) out.push_back(c);
    contacts_seen_[k] = c.contacts;
  });
  return out;
}

std::vector<RobotContacts> FleetBench::contacts() const {
  std::vector<RobotContacts> out;
  if (!bodies_) return out;
  for_each_pair([&](std::size_t, const RobotContacts& c) {
    if (c.contacts > 0) out.push_back(c);
  });
  return out;
}

}  // namespace cairn::hil

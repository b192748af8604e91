#include "firmware/robot_bridge.hpp"

#include <cstdio>

#include "common/log.hpp"

namespace cairn::firmware {
namespace {

// Odometry and features feed the base's EKF: reliable and transient-local, so a base
// that restarts fetches what it missed (its readers ask for the same history).
constexpr std::int32_t kFusionHistory = 512;

cairn_RobotMode mode_of(StopReason stop, bool ever_ready) {
  if (stop == StopReason::kNone) return cairn_MODE_RUNNING;
  if (!ever_ready) return cairn_MODE_BOOTING;
  return stop == StopReason::kDrivesNotReady ? cairn_MODE_FAULT : cairn_MODE_STOPPED;
}

std::uint32_t low32(std::uint64_t v) { return static_cast<std::uint32_t>(v); }

}  // namespace

RobotBridge::RobotBridge(const dds::Participant& pp, const RobotConfig& cfg)
    : cfg_(cfg),
      status_topic_(pp),
      odom_topic_(pp),
      laser_topic_(pp),
      feat_topic_(pp),
      corr_topic_(pp),
      task_topic_(pp),
      reset_topic_(pp),
      stop_topic_(pp),
      tile_topic_(pp),
      bid_topic_(pp),
      status_writer_(pp, status_topic_, [&] {
        dds::QosSpec q = dds::state_qos();
        q.liveliness_lease = cfg.liveliness_lease;
        return q;
      }(), cfg.id),
      odom_writer_(pp, odom_topic_, dds::latched_qos(kFusionHistory), cfg.id),
      laser_writer_(pp, laser_topic_, dds::sensor_qos(), cfg.id),
      feat_writer_(pp, feat_topic_, dds::latched_qos(kFusionHistory), cfg.id),
      corr_reader_(pp, corr_topic_, dds::latched_qos()),
      task_reader_(pp, task_topic_, dds::latched_qos()),
      reset_reader_(pp, reset_topic_, dds::state_qos(4)),  // volatile: never an old reset
      stop_reader_(pp, stop_topic_, dds::state_qos(4)),    // volatile: never an old stop
      tile_reader_(pp, tile_topic_, dds::latched_qos()),  // as the base writes them: a late robot gets all
      bid_writer_(pp, bid_topic_, dds::state_qos(1), cfg.id),  // the latest bid is what counts
      global_map_(cfg.global_map) {
  status_.robot_id = cfg.id;
  dds::set_text(status_.name, cfg.name);
  status_.mode = cairn_MODE_IDLE;
}

template <typename T>
void RobotBridge::write(dds::Writer<T>& w, const T& sample, std::uint64_t* count) {
  if (w.write(sample)) {
    ++*count;
    return;
  }
  // Counted and reported in RobotStatus.queue_overflows; the first and every 1000th logged.
  if (counters_.write_failures++ % 1000 == 0) {
    CAIRN_LOG_WARN("bridge", "write failed on {}: {} ({} failures so far)", dds::TopicTraits<T>::name,
                   dds_strretcode(w.last_error()), counters_.write_failures);
  }
}

std::size_t RobotBridge::forward(Executive& exec) {
  const std::uint64_t before = counters_.odometry + counters_.lasers + counters_.features;
  msg::OdometryIncrement inc;
  cairn_OdometryIncrement inc_dds{};
  while (exec.pop_odometry(&inc)) {
    dds::to_dds(inc, &inc_dds);
    write(odom_writer_, inc_dds, &counters_.odometry);
  }
  while (exec.pop_features(feat_.get())) {
    dds::to_dds(*feat_, feat_dds_.get());
    write(feat_writer_, *feat_dds_, &counters_.features);
  }
  while (exec.pop_laser(laser_.get())) {
    dds::to_dds(*laser_, laser_dds_.get());
    write(laser_writer_, *laser_dds_, &counters_.lasers);
  }
  return static_cast<std::size_t>(counters_.odometry + counters_.lasers + counters_.features - before);
}

void RobotBridge::publish_status(Executive* exec, Nanos now) {
  cairn_RobotStatus& s = status_;
  s.seq++;
  s.stamp_ns = now;
  s.log_dropped = low32(logger().dropped());
  if (exec) {
    const RtSnapshot r = exec->rt_snapshot();
    ever_ready_ = ever_ready_ || r.stop == StopReason::kNone;
    s.mode = mode_of(r.stop, ever_ready_);
    s.stop_reason = static_cast<std::uint8_t>(r.stop);
    if (r.stop == StopReason::kResetRequired) {  // the operator needs the cause before resetting
      char text[96];
      std::snprintf(text, sizeof text, "e-stop latched (%s): reset required", latch_cause_text(r.latch_cause));
      dds::set_text(s.stop_text, text);
    } else {
      dds::set_text(s.stop_text, stop_reason_text(r.stop));
    }
    s.remote_stops = r.remote_stops;
    s.local_pose = {r.local_pose.x, r.local_pose.y, r.local_pose.theta};
    s.loop_period_mean_us = r.period_mean_us;
    s.loop_period_p99_us = r.period_p99_us;
    s.loop_jitter_max_us = r.jitter_max_us;
    s.loop_cycles = low32(r.cycles);
    s.deadline_misses = low32(r.misses);
    s.queue_overflows = low32(r.overflows + r.publish_drops + counters_.write_failures);
    s.battery_voltage = static_cast<float>(r.battery_voltage);
    s.battery_soc = static_cast<float>(r.battery_soc);
    std::array<DeviceSnapshot, 4> devs;
    const std::size_t n = std::min<std::size_t>(exec->devices(&devs), cairn_MAX_DEVICES);
    s.n_devices = static_cast<std::uint8_t>(n);
    for (std::size_t i = 0; i < n; ++i) {
      cairn_DeviceStatus& d = s.devices[i];
      dds::set_text(d.name, devs[i].name.data());
      d.state = devs[i].state;
      dds::set_text(d.reason, devs[i].reason.data());
      d.frames = devs[i].frames;
      d.crc_errors = devs[i].crc_errors;
      d.resyncs = devs[i].resyncs;
      d.timeouts = devs[i].timeouts;
      d.recoveries = devs[i].recoveries;
      d.errors = devs[i].errors;
    }
  }
  write(status_writer_, s, &counters_.statuses);
}

std::size_t RobotBridge::take_resets(Executive* exec) {
  std::size_t n = 0;
  reset_reader_.take([&](const cairn_SafetyReset& r, const dds_sample_info_t&) {
    msg::SafetyReset m;
    dds::from_dds(r, &m);
    if (m.robot_id != cfg_.id) return;
    ++n;
    ++counters_.resets;
    if (exec && !exec->request_reset(m.remote_stops_seen)) {
      CAIRN_LOG_WARN("bridge", "e-stop reset #{} by '{}' refused: asked before the latest remote e-stop (it saw {} of them)", m.seq,
                     std::string_view(m.issued_by.data()), m.remote_stops_seen);
      return;
    }
    CAIRN_LOG_INFO("bridge", "e-stop reset #{} requested over DDS by '{}'", m.seq, std::string_view(m.issued_by.data()));
  });
  return n;
}

std::size_t RobotBridge::take_stops(Executive* exec) {
  std::size_t n = 0;
  stop_reader_.take([&](const cairn_SafetyStop& s, const dds_sample_info_t&) {
    msg::SafetyStop m;
    dds::from_dds(s, &m);
    if (m.robot_id != cfg_.id && m.robot_id != 0) return;
    ++n;
    ++counters_.remote_stops;
    CAIRN_LOG_WARN("bridge", "remote e-stop #{} ({}) by '{}': latched until a reset", m.seq,
                   m.robot_id == 0 ? "every robot" : "this robot", std::string_view(m.issued_by.data()));
    if (exec) exec->request_remote_stop();
  });
  return n;
}

std::size_t RobotBridge::take_map_tiles() {
  std::size_t n = 0;
  tile_reader_.take([&](const cairn_MapTile& t, const dds_sample_info_t&) {
    if (t.robot_id != 0) return;  // only the fused global map
    if (global_map_.apply(map_tile_view(t)) == GlobalMap::Applied::kStored) ++n;
  });
  return n;
}

void RobotBridge::publish_bid(const msg::Bid& bid) {
  dds::to_dds(bid, bid_dds_.get());
  write(bid_writer_, *bid_dds_, &counters_.bids);
}

void RobotBridge::dispose() { status_writer_.dispose(status_); }

}  // namespace cairn::firmware

#include "basestation/fusion_node.hpp"

#include <cstdio>
#include <type_traits>

namespace cairn::base {

FusionNode::FusionNode(const dds::Participant& pp, const BaseConfig& cfg)
    : cfg_(cfg),
      fusion_(cfg.fusion),
      store_(cfg.state_dir, cfg.snapshot_period),
      odom_topic_(pp),
      feat_topic_(pp),
      corr_topic_(pp),
      odom_reader_(pp, odom_topic_, dds::latched_qos(cfg.history_depth)),
      feat_reader_(pp, feat_topic_, dds::latched_qos(cfg.history_depth)),
      corr_writer_(pp, corr_topic_, dds::latched_qos()),
      map_publisher_(pp) {}

std::string FusionNode::restore() {
  const RestoreReport r = store_.restore(&fusion_);
  // Short (the logger keeps 192 characters): the store logs its own errors in full.
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "state in %s: %s, %llu refused; %s; replayed %llu odometry + %llu features from %llu log(s), %llu torn "
                "(%llu bytes), %llu failed; %zu robot(s), %zu feature(s)",
                store_.dir().c_str(), r.snapshot_loaded ? "snapshot loaded" : "no snapshot (fresh start)",
                static_cast<unsigned long long>(r.snapshots_rejected), r.snapshot_written ? "persisting" : "NOT PERSISTING",
                static_cast<unsigned long long>(r.replayed_odometry), static_cast<unsigned long long>(r.replayed_features),
                static_cast<unsigned long long>(r.logs_replayed), static_cast<unsigned long long>(r.torn_records),
                static_cast<unsigned long long>(r.torn_bytes), static_cast<unsigned long long>(r.failed_records),
                fusion_.robots().size(), fusion_.filter().feature_count());
  return buf;
}

template <typename M>
void FusionNode::accept(const M& m, Nanos now) {
  // Checked before it is logged: the log holds only messages that passed the message checks.
  if (const auto bad = fusion_.check(m)) {
    fusion_.count(*bad);
    return;
  }
  store_.append(m, now);  // write-ahead: logged before it changes the state
  try {
    if constexpr (std::is_same_v<M, msg::OdometryIncrement>) {
      fusion_.on_odometry(m);
    } else {
      fusion_.on_features(m);
    }
  } catch (const std::exception&) {
    fusion_.count(Reject::kApplyFailed);  // never out of the loop
  }
}

void FusionNode::poll(Nanos now) {
  // Odometry first, so features that refer to it can be applied at once.
  odom_reader_.take([&](const cairn_OdometryIncrement& s, const dds_sample_info_t&) {
    msg::OdometryIncrement m;
    if (dds::from_dds(s, &m)) accept(m, now);
    else fusion_.count(Reject::kMalformed);
  });
  feat_reader_.take([&](const cairn_FeatureObservations& s, const dds_sample_info_t&) {
    msg::FeatureObservations m;
    if (dds::from_dds(s, &m)) accept(m, now);
    else fusion_.count(Reject::kMalformed);
  });
  store_.maybe_snapshot(fusion_, now);
  if (now >= next_correction_) {
    next_correction_ = now + cfg_.correction_period;
    for (std::uint16_t id : fusion_.robots()) {
      msg::PoseCorrection c;
      if (fusion_.correction(id, now, &c)) {
        c.seq = ++correction_seq_;
        cairn_PoseCorrection out{};
        dds::to_dds(c, &out);
        corr_writer_.write(out);
      }
    }
  }
  if (now >= next_map_) {
    next_map_ = now + cfg_.map_period;
    fusion_.landmarks(&landmarks_);
    map_publisher_.publish(landmarks_, ++map_seq_, now);
  }
}

std::string FusionNode::robot_lines(const char* prefix) const {
  std::string out;
  for (std::uint16_t id : fusion_.robots()) {
    const auto p = fusion_.progress(id);
    if (!p) continue;
    char line[240];
    int n = std::snprintf(line, sizeof line, "%sfusion robot %u: boot %08x, odometry seq %u, features seq %u, ", prefix,
                          static_cast<unsigned>(id), p->boot_epoch, p->odom_seq, p->feature_seq);
    msg::PoseCorrection c;
    if (n > 0 && fusion_.correction(id, 0, &c)) {
      std::snprintf(line + n, sizeof line - static_cast<std::size_t>(n), "localised at %.3f %.3f %.4f rad\n", c.global_pose.x,
                    c.global_pose.y, c.global_pose.theta);
    } else if (n > 0) {
      std::snprintf(line + n, sizeof line - static_cast<std::size_t>(n), "not localised\n");
    }
    out += line;
  }
  return out;
}

std::string FusionNode::summary() const {
  const FusionCounters& c = fusion_.counters();
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "fusion: odometry %llu applied (%llu dup, %llu gaps), features %llu applied (%llu dup, %llu late, %llu stale), "
                "observations %llu used / %llu new, robots seen %llu (%llu unread, %llu of them paired; %llu fused), landmarks pruned %llu, "
                "robots %zu (%llu localised, %llu restarted), map %zu, "
                "state %s; rejected: %s",
                static_cast<unsigned long long>(c.odometry_applied), static_cast<unsigned long long>(c.odometry_duplicates),
                static_cast<unsigned long long>(c.odometry_gaps), static_cast<unsigned long long>(c.feature_messages_applied),
                static_cast<unsigned long long>(c.feature_duplicates), static_cast<unsigned long long>(c.feature_late),
                static_cast<unsigned long long>(c.feature_stale), static_cast<unsigned long long>(c.observations_used),
                static_cast<unsigned long long>(c.observations_new_features), static_cast<unsigned long long>(c.robot_sightings),
                static_cast<unsigned long long>(c.robot_sightings_unidentified), static_cast<unsigned long long>(c.robot_sightings_paired),
                static_cast<unsigned long long>(c.robot_observations_used),
                static_cast<unsigned long long>(c.landmarks_pruned),
                fusion_.robots().size(), static_cast<unsigned long long>(c.robots_localized),
                static_cast<unsigned long long>(c.robots_restarted), fusion_.filter().feature_count(),
                fusion_.finite() ? "finite" : "NOT FINITE", c.rejected.summary().c_str());
  const PersistCounters& p = store_.counters();
  char pbuf[384];
  std::snprintf(pbuf, sizeof pbuf,
                "; persistence: %s, %llu logged, %llu in memory only, snapshots %llu written / %llu failed, "
                "write errors %llu (disk full %llu)",
                store_.persisting() ? "on" : "SUSPENDED", static_cast<unsigned long long>(p.records_appended),
                static_cast<unsigned long long>(p.records_not_persisted), static_cast<unsigned long long>(p.snapshots_written),
                static_cast<unsigned long long>(p.snapshots_failed), static_cast<unsigned long long>(p.write_errors),
                static_cast<unsigned long long>(p.disk_full));
  std::string out = buf;
  out += pbuf;
  if (!store_.persisting() && !store_.last_error().empty()) out += " (" + store_.last_error() + ")";
  return out;
}

}  // namespace cairn::base

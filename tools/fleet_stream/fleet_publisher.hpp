// Publishes a fleet stream (fleet_scenario.hpp) over DDS as the robots would: odometry and
// features on reliable, transient-local writers with a deep history (a base that starts or
// restarts late still fetches what it missed), each robot's in its own partition. Used by
// cairn-fuzz-base and the tests' feeder.
#pragma once

#include <memory>
#include <variant>

#include "common/dds/topics.hpp"
#include "tools/fleet_stream/fleet_scenario.hpp"

namespace cairn::fleet_stream {

class FleetPublisher {
 public:
  /// Robots 1 .. robots (as make_fleet_scenario numbers them).
  FleetPublisher(const dds::Participant& pp, int robots, int depth)
      : odom_topic_(pp),
        feat_topic_(pp),
        odom_(pp, odom_topic_, dds::latched_qos(depth)),
        feat_(pp, feat_topic_, dds::latched_qos(depth)),
        feat_sample_(std::make_unique<cairn_FeatureObservations>()) {
    for (int r = 1; r <= robots; ++r) {  // all writers now: the waits below cover each
      odom_.writer(static_cast<std::uint16_t>(r));
      feat_.writer(static_cast<std::uint16_t>(r));
    }
  }

  /// Writes one message; returns the odometry it carried (nullptr for features).
  const msg::OdometryIncrement* publish(const FleetMessage& m) {
    if (const auto* od = std::get_if<msg::OdometryIncrement>(&m)) {
      cairn_OdometryIncrement out{};
      dds::to_dds(*od, &out);
      odom_.write(out);
      ++odometry_;
      return od;
    }
    *feat_sample_ = {};
    dds::to_dds(std::get<msg::FeatureObservations>(m), feat_sample_.get());
    feat_.write(*feat_sample_);
    ++features_;
    return nullptr;
  }

  bool wait_for_base(Nanos timeout) { return odom_.wait_for_readers(1, timeout); }
  /// Until both writers have n readers; false on timeout.
  bool wait_for_readers(std::uint32_t n, Nanos timeout) {
    return odom_.wait_for_readers(n, timeout) && feat_.wait_for_readers(n, timeout);
  }
  std::uint64_t odometry() const { return odometry_; }
  std::uint64_t features() const { return features_; }

 private:
  dds::Topic<cairn_OdometryIncrement> odom_topic_;
  dds::Topic<cairn_FeatureObservations> feat_topic_;
  dds::RobotWriters<cairn_OdometryIncrement> odom_;
  dds::RobotWriters<cairn_FeatureObservations> feat_;
  std::unique_ptr<cairn_FeatureObservations> feat_sample_;  // 1.9 kB: not on the stack
  std::uint64_t odometry_ = 0, features_ = 0;
};

}  // namespace cairn::fleet_stream

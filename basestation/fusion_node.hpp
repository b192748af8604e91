// The base station's DDS side of fusion: takes every robot's OdometryIncrement and
// FeatureObservations (reliable, transient-local: a restarted base fetches what it
// missed), converts them to Cairn's messages (common/dds/convert.hpp; a sample that had to
// be clamped is counted invalid and dropped), logs each before applying it, and publishes
// PoseCorrection per robot and the FeatureMap in pages.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "basestation/base_config.hpp"
#include "basestation/fusion.hpp"
#include "basestation/map_publisher.hpp"
#include "basestation/state_store.hpp"
#include "common/dds/topics.hpp"

namespace cairn::base {

class FusionNode {
 public:
  FusionNode(const dds::Participant& pp, const BaseConfig& cfg);
  /// Restores persisted state; returns a one-line report for the log.
  std::string restore();
  /// Takes and applies whatever arrived; publishes on schedule. Never blocks.
  void poll(Nanos now);
  /// One line with the counters, for the console.
  std::string summary() const;
  /// One line per robot, each after `prefix`: "fusion robot ID: boot B, odometry seq N,
  /// features seq M, localised at X Y THETA rad|not localised" (the global estimate; the base's
  /// table and its final lines).
  std::string robot_lines(const char* prefix = "") const;
  const Fusion& fusion() const { return fusion_; }
  /// Odometry and features dropped for a robot_id other than their writer's partition's.
  std::uint64_t foreign_samples() const { return odom_reader_.foreign_samples() + feat_reader_.foreign_samples(); }
  const StateStore& store() const { return store_; }

 private:
  template <typename M>
  void accept(const M& m, Nanos now);

  const BaseConfig& cfg_;
  Fusion fusion_;
  StateStore store_;
  dds::Topic<cairn_OdometryIncrement> odom_topic_;
  dds::Topic<cairn_FeatureObservations> feat_topic_;
  dds::Topic<cairn_PoseCorrection> corr_topic_;
  dds::Reader<cairn_OdometryIncrement> odom_reader_;
  dds::Reader<cairn_FeatureObservations> feat_reader_;
  dds::Writer<cairn_PoseCorrection> corr_writer_;
  FeatureMapPublisher map_publisher_;
  Nanos next_correction_ = 0, next_map_ = 0;
  std::uint32_t correction_seq_ = 0, map_seq_ = 0;
  std::vector<msg::Landmark> landmarks_;
};

}  // namespace cairn::base

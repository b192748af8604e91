// QoS profiles for Cairn topics.
#pragma once

#include <dds/dds.h>

#include <cstdint>

#include "common/clock.hpp"

namespace cairn::dds {

struct QosSpec {
  bool reliable = true;
  bool transient_local = false;
  std::int32_t depth = 1;   // keep-last depth per instance (per robot); <= 0 means keep-all
  Nanos liveliness_lease = 0;  // 0 = infinite; else AUTOMATIC liveliness with this lease
};

/// Tasks, corrections, map snapshots: reliable, transient-local (late joiners get the latest).
inline QosSpec latched_qos(std::int32_t depth = 1) { return {true, true, depth, 0}; }
/// High-rate data (scans, odometry, features): best-effort keep-last.
inline QosSpec sensor_qos(std::int32_t depth = 4) { return {false, false, depth, 0}; }
/// Reliable keep-last state (robot status, bids).
inline QosSpec state_qos(std::int32_t depth = 1) { return {true, false, depth, 0}; }

/// Builds a dds_qos_t (caller deletes with dds_delete_qos).
dds_qos_t* make_qos(const QosSpec& spec);

}  // namespace cairn::dds

// One DDS partition per robot for the topics a robot publishes (TopicTraits<T>::per_robot).
// DDS Security grants topics, not key values; the permissions (scripts/fleet-keys.sh) grant
// robot N's certificate those topics only in partition "cairn-robot-N", so a writer in that
// partition is robot N, and a reader drops a sample it writes keyed to another robot.
#pragma once

#include <dds/dds.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>
#include <unordered_map>

namespace cairn::dds {

inline constexpr std::string_view kRobotPartitionPrefix = "cairn-robot-";
/// Every robot's partition: a reader's partition may be a wildcard (the base reads this one).
inline constexpr const char* kAllRobotsPartition = "cairn-robot-*";

/// A robot's partition name, kept inline (no heap: a robot's writers are made at start-up).
struct RobotPartition {
  std::array<char, 24> text{};
  const char* c_str() const { return text.data(); }
};
/// "cairn-robot-<id>".
RobotPartition robot_partition(std::uint16_t robot_id);
/// The robot whose partition this is, or nullopt (another partition, the wildcard, "").
std::optional<std::uint16_t> robot_of_partition(std::string_view partition);

/// The robot whose partition a writer with this QoS writes in: nullopt unless it has exactly
/// one partition and that is a robot's.
std::optional<std::uint16_t> robot_of_writer_qos(const dds_qos_t* qos);

/// A publisher (or subscriber) QoS with the one partition `name`; caller deletes.
dds_qos_t* make_partition_qos(const char* name);

/// Which robot's partition each writer a reader matched writes in, asked of DDS once per
/// writer. For a reader of a per-robot topic: a sample keyed to another robot is foreign.
class WriterRobots {
 public:
  /// nullopt if the writer is in no robot's partition, or is gone before we asked (an
  /// unknown writer is not trusted).
  std::optional<std::uint16_t> of(dds_entity_t reader, dds_instance_handle_t publication);
  /// True unless `publication` writes in robot `robot_id`'s partition.
  bool foreign(dds_entity_t reader, dds_instance_handle_t publication, std::uint16_t robot_id) {
    const std::optional<std::uint16_t> robot = of(reader, publication);
    return !robot || *robot != robot_id;
  }

 private:
  static constexpr std::size_t kMaxCached = 1024;  // writers come and go with robots
  std::unordered_map<dds_instance_handle_t, std::optional<std::uint16_t>> robots_;
};

}  // namespace cairn::dds

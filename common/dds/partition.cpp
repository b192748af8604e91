#include "common/dds/partition.hpp"

#include <charconv>

namespace cairn::dds {

RobotPartition robot_partition(std::uint16_t robot_id) {
  RobotPartition p;
  char* out = p.text.data();
  for (const char c : kRobotPartitionPrefix) *out++ = c;
  out = std::to_chars(out, p.text.data() + p.text.size() - 1, robot_id).ptr;  // 12 + 5 digits fit
  *out = '\0';
  return p;
}

std::optional<std::uint16_t> robot_of_partition(std::string_view partition) {
  if (!partition.starts_with(kRobotPartitionPrefix)) return std::nullopt;
  const std::string_view digits = partition.substr(kRobotPartitionPrefix.size());
  if (digits.empty() || (digits.size() > 1 && digits.front() == '0')) return std::nullopt;  // one name per robot
  std::uint16_t id = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), id);
  if (ec != std::errc() || end != digits.data() + digits.size()) return std::nullopt;
  return id;
}

std::optional<std::uint16_t> robot_of_writer_qos(const dds_qos_t* qos) {
  std::uint32_t n = 0;
  char** names = nullptr;
  if (qos == nullptr || !dds_qget_partition(qos, &n, &names)) return std::nullopt;
  const std::optional<std::uint16_t> robot = n == 1 ? robot_of_partition(names[0]) : std::nullopt;
  for (std::uint32_t i = 0; i < n; ++i) dds_free(names[i]);
  dds_free(names);
  return robot;
}

dds_qos_t* make_partition_qos(const char* name) {
  dds_qos_t* q = dds_create_qos();
  dds_qset_partition1(q, name);
  return q;
}

std::optional<std::uint16_t> WriterRobots::of(dds_entity_t reader, dds_instance_handle_t publication) {
  const auto it = robots_.find(publication);
  if (it != robots_.end()) return it->second;
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, publication);
  if (ep == nullptr) return std::nullopt;  // not cached: a writer met again later is asked again
  const std::optional<std::uint16_t> robot = robot_of_writer_qos(ep->qos);
  dds_builtintopic_free_endpoint(ep);
  if (robots_.size() >= kMaxCached) robots_.clear();
  robots_.emplace(publication, robot);
  return robot;
}

}  // namespace cairn::dds

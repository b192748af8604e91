#include "tools/recording/raw_topic.hpp"

#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_sertype.h>

#include <algorithm>
#include <cstdlib>
#include <memory>

#include "common/dds/error.hpp"
#include "common/dds/qos.hpp"

namespace cairn::recording {

dds::Entity create_topic(const dds::Participant& pp, const TopicEntry& t) {
  const dds_entity_t h = dds_create_topic(pp.handle(), t.descriptor, t.name, nullptr, nullptr);
  dds::check(h, std::string("dds_create_topic(") + t.name + ")");
  return dds::Entity(h);
}

std::optional<std::uint16_t> cdr_robot_id(std::span<const std::uint8_t> cdr) {
  // The encapsulation header: 2 bytes of kind (odd: little endian), 2 of options. XCDR1 and
  // XCDR2 final types start with the first member; a delimited XCDR2 type with a 4-byte length.
  if (cdr.size() < 4 || cdr[0] != 0) return std::nullopt;
  std::size_t at = 4;
  switch (cdr[1]) {
    case 0x00: case 0x01: case 0x06: case 0x07: break;  // CDR_BE/LE, CDR2_BE/LE
    case 0x08: case 0x09: at = 8; break;                 // D_CDR2_BE/LE
    default: return std::nullopt;
  }
  if (cdr.size() < at + 2) return std::nullopt;
  const bool little = (cdr[1] & 1) != 0;
  return static_cast<std::uint16_t>(little ? cdr[at] | (cdr[at + 1] << 8) : (cdr[at] << 8) | cdr[at + 1]);
}

namespace {
// In `parent` (a participant, or a publisher or subscriber with a partition).
dds::Entity make_endpoint(dds_entity_t parent, dds_entity_t topic, const dds::QosSpec& spec, bool writer,
                          const char* name) {
  dds_qos_t* q = dds::make_qos(spec);
  const dds_entity_t h = writer ? dds_create_writer(parent, topic, q, nullptr) : dds_create_reader(parent, topic, q, nullptr);
  dds_delete_qos(q);
  dds::check(h, std::string(writer ? "dds_create_writer(" : "dds_create_reader(") + name + ")");
  return dds::Entity(h);
}

dds::Entity make_partitioned(const dds::Participant& pp, const char* partition, bool publisher, const char* name) {
  dds_qos_t* q = dds::make_partition_qos(partition);
  const dds_entity_t h = publisher ? dds_create_publisher(pp.handle(), q, nullptr) : dds_create_subscriber(pp.handle(), q, nullptr);
  dds_delete_qos(q);
  dds::check(h, std::string(publisher ? "dds_create_publisher(" : "dds_create_subscriber(") + name + ")");
  return dds::Entity(h);
}

// Cyclone 0.10 has no call that returns a topic's serialization type; a sample written and
// taken back on a private topic of the same type carries it (the domain shares one type
// object per type, so it is the real topic's). The private topic is deleted at once.
const ddsi_sertype* probe_sertype(const dds::Participant& pp, const TopicEntry& t) {
  const std::string name = std::string("cairn_replay_probe_") + t.name;
  dds::Entity topic(dds::check(dds_create_topic(pp.handle(), t.descriptor, name.c_str(), nullptr, nullptr), "dds_create_topic(" + name + ")"));
  const dds::QosSpec local{true, false, 1, 0};
  dds::Entity reader = make_endpoint(pp.handle(), topic.get(), local, false, name.c_str());
  dds::Entity writer = make_endpoint(pp.handle(), topic.get(), local, true, name.c_str());
  std::unique_ptr<void, decltype(&std::free)> sample(std::calloc(1, t.descriptor->m_size), &std::free);
  dds::check(dds_write(writer.get(), sample.get()), "dds_write(" + name + ")");
  ddsi_serdata* sd = nullptr;
  dds_sample_info_t info;
  const dds_return_t n = dds_takecdr(reader.get(), &sd, 1, &info, DDS_ANY_STATE);
  dds::check(n, "dds_takecdr(" + name + ")");
  if (n != 1) throw dds::DdsError("probing the serialization type of " + std::string(t.name), DDS_RETCODE_ERROR);
  const ddsi_sertype* type = ddsi_sertype_ref(sd->type);
  ddsi_serdata_unref(sd);
  return type;
}
}  // namespace

RawReader::RawReader(const dds::Participant& pp, const TopicEntry& t) : topic_(&t), topic_entity_(create_topic(pp, t)) {
  dds_entity_t parent = pp.handle();
  if (t.per_robot) {
    subscriber_ = make_partitioned(pp, dds::kAllRobotsPartition, false, t.name);
    parent = subscriber_.get();
  }
  reader_ = make_endpoint(parent, topic_entity_.get(), t.record_qos, false, t.name);
}

std::size_t RawReader::take(const std::function<void(std::span<const std::uint8_t>, std::int64_t)>& on_sample) {
  constexpr std::uint32_t kBatch = 32;
  std::size_t total = 0;
  for (;;) {
    ddsi_serdata* sds[kBatch] = {};
    dds_sample_info_t infos[kBatch];
    const dds_return_t n = dds_takecdr(reader_.get(), sds, kBatch, infos, DDS_ANY_STATE);
    dds::check(n, std::string("dds_takecdr(") + topic_->name + ")");
    for (int i = 0; i < n; ++i) {
      if (infos[i].valid_data) {
        const std::uint32_t size = ddsi_serdata_size(sds[i]);
        buf_.resize(size);
        ddsi_serdata_to_ser(sds[i], 0, size, buf_.data());
        const std::optional<std::uint16_t> robot = topic_->per_robot ? cdr_robot_id(buf_) : std::nullopt;
        if (topic_->per_robot && (!robot || writer_robots_.foreign(reader_.get(), infos[i].publication_handle, *robot))) {
          ++foreign_samples_;
        } else {
          on_sample(buf_, infos[i].source_timestamp);
          ++total;
        }
      } else {
        ++instance_events_;
      }
      ddsi_serdata_unref(sds[i]);
    }
    if (n < static_cast<dds_return_t>(kBatch)) break;
  }
  return total;
}

RawWriter::RawWriter(const dds::Participant& pp, const TopicEntry& t) : pp_(&pp), topic_(&t), topic_entity_(create_topic(pp, t)) {
  if (!t.per_robot) writer_ = make_endpoint(pp.handle(), topic_entity_.get(), t.replay_qos, true, t.name);
  type_ = probe_sertype(pp, t);
}

RawWriter::~RawWriter() {
  writer_.reset();
  robots_.clear();
  if (type_) ddsi_sertype_unref(const_cast<ddsi_sertype*>(type_));
}

void RawWriter::add_robot(std::uint16_t robot_id) {
  if (!topic_->per_robot || robots_.contains(robot_id)) return;
  RobotWriter w;
  w.publisher = make_partitioned(*pp_, dds::robot_partition(robot_id).c_str(), true, topic_->name);
  w.writer = make_endpoint(w.publisher.get(), topic_entity_.get(), topic_->replay_qos, true, topic_->name);
  robots_.emplace(robot_id, std::move(w));
}

dds_entity_t RawWriter::writer_for(std::span<const std::uint8_t> cdr) {
  if (!topic_->per_robot) return writer_.get();
  const std::optional<std::uint16_t> robot = cdr_robot_id(cdr);
  if (!robot) return 0;
  add_robot(*robot);
  return robots_.at(*robot).writer.get();
}

std::string RawWriter::write(std::span<const std::uint8_t> cdr) {
  ddsrt_iovec_t iov;
  iov.iov_base = const_cast<std::uint8_t*>(cdr.data());
  iov.iov_len = static_cast<ddsrt_iov_len_t>(cdr.size());
  // Rejects bytes that are not a valid sample of the type (it checks the CDR).
  ddsi_serdata* sd = ddsi_serdata_from_ser_iov(type_, SDK_DATA, 1, &iov, cdr.size());
  if (!sd) return "not a valid " + std::string(topic_->type_name) + " sample";
  const dds_entity_t writer = writer_for(cdr);
  if (writer <= 0) {
    ddsi_serdata_unref(sd);
    return "no robot_id in the " + std::string(topic_->type_name) + " sample";
  }
  const dds_return_t rc = dds_writecdr(writer, sd);  // takes the reference
  if (rc < 0) return std::string("dds_writecdr: ") + dds_strretcode(rc);
  return "";
}

namespace {
std::uint32_t matched_readers(dds_entity_t writer) {
  dds_publication_matched_status_t st{};
  dds::check(dds_get_publication_matched_status(writer, &st), "dds_get_publication_matched_status");
  return st.current_count;
}
}  // namespace

std::uint32_t RawWriter::matched() const {
  if (!topic_->per_robot) return matched_readers(writer_.get());
  std::uint32_t fewest = 0;
  bool first = true;
  for (const auto& [id, w] : robots_) {
    const std::uint32_t n = matched_readers(w.writer.get());
    fewest = first ? n : std::min(fewest, n);
    first = false;
  }
  return fewest;  // no robot's writer yet: none matched
}

bool RawWriter::wait_for_acks(std::int64_t timeout_ns) const {
  if (!topic_->per_robot) return dds_wait_for_acks(writer_.get(), timeout_ns) == DDS_RETCODE_OK;
  bool all = true;
  for (const auto& [id, w] : robots_) all = dds_wait_for_acks(w.writer.get(), timeout_ns) == DDS_RETCODE_OK && all;
  return all;
}

}  // namespace cairn::recording

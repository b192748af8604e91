#include "tools/recording/recorder.hpp"

#include "common/dds/error.hpp"

namespace cairn::recording {

Recorder::Recorder(const dds::Participant& pp, mcap::Writer& out) : out_(out) {
  waitset_ = dds::Entity(dds::check(dds_create_waitset(pp.handle()), "dds_create_waitset"));
  for (const TopicEntry& t : cairn_topics()) {
    Channel c;
    c.reader = std::make_unique<RawReader>(pp, t);
    const std::uint16_t schema = out_.add_schema({t.type_name, "omgidl", cairn_idl_text()});
    c.id = out_.add_channel({schema, t.name, "cdr", {}});
    const dds_entity_t cond = dds::check(dds_create_readcondition(c.reader->handle(), DDS_ANY_STATE), "dds_create_readcondition");
    dds::check(dds_waitset_attach(waitset_.get(), cond, 0), "dds_waitset_attach");
    channels_.push_back(std::move(c));
  }
}

std::size_t Recorder::poll(std::int64_t timeout_ns) {
  dds::check(dds_waitset_wait(waitset_.get(), nullptr, 0, timeout_ns), "dds_waitset_wait");
  std::size_t n = 0;
  for (Channel& c : channels_) {
    n += c.reader->take([&](std::span<const std::uint8_t> cdr, std::int64_t source_ns) {
      // log_time: when the recorder got it; publish_time: the writer's source timestamp.
      const dds_time_t now = dds_time();
      out_.add_message(c.id, ++c.sequence, static_cast<std::uint64_t>(now),
                       static_cast<std::uint64_t>(source_ns > 0 ? source_ns : now), cdr.data(), cdr.size());
    });
  }
  return n;
}

std::string Recorder::counts() const {
  std::string s;
  for (const Channel& c : channels_) {
    if (c.sequence == 0) continue;
    if (!s.empty()) s += ", ";
    s += std::string(c.reader->topic().name) + " " + std::to_string(c.sequence);
  }
  return s.empty() ? "no messages" : s;
}

std::uint64_t Recorder::instance_events() const {
  std::uint64_t n = 0;
  for (const Channel& c : channels_) n += c.reader->instance_events();
  return n;
}

}  // namespace cairn::recording

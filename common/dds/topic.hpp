// Typed topic, writer and reader over the Cyclone DDS C API.
//
// A type T (an idlc-generated C struct) is usable once TopicTraits<T> gives its
// descriptor and topic name (see common/dds/topics.hpp).
#pragma once

#include <dds/dds.h>

#include <cstdint>
#include <initializer_list>
#include <map>
#include <memory>
#include <string>

#include "common/clock.hpp"
#include "common/dds/error.hpp"
#include "common/dds/participant.hpp"
#include "common/dds/partition.hpp"
#include "common/dds/qos.hpp"

namespace cairn::dds {

template <typename T>
struct TopicTraits;  // { static const dds_topic_descriptor_t* descriptor(); static constexpr const char* name; }

/// A topic robots publish, each robot in its own partition (TopicTraits<T>::per_robot).
template <typename T>
concept PerRobotTopic = requires { requires TopicTraits<T>::per_robot; };

template <typename T>
class Topic {
 public:
  /// The type's standard topic, or another topic of the same type under `name`.
  explicit Topic(const Participant& pp, const char* name = TopicTraits<T>::name) : name_(name) {
    const dds_entity_t t = dds_create_topic(pp.handle(), TopicTraits<T>::descriptor(), name, nullptr, nullptr);
    check(t, std::string("dds_create_topic(") + name + ")");
    topic_ = Entity(t);
  }
  dds_entity_t handle() const { return topic_.get(); }
  const char* name() const { return name_; }

 private:
  const char* name_;
  Entity topic_;
};

template <typename T>
class Writer {
 public:
  /// A writer of a topic the base or a tool publishes (the default partition).
  Writer(const Participant& pp, const Topic<T>& topic, const QosSpec& qos)
    requires(!PerRobotTopic<T>)
  {
    create(pp.handle(), topic, qos);
  }
  /// A writer of a topic robots publish, in robot `robot_id`'s partition: the only one a
  /// robot's permissions let it write in, and the robot readers hold its samples to.
  Writer(const Participant& pp, const Topic<T>& topic, const QosSpec& qos, std::uint16_t robot_id)
    requires PerRobotTopic<T>
  {
    dds_qos_t* pq = make_partition_qos(robot_partition(robot_id).c_str());
    const dds_entity_t pub = dds_create_publisher(pp.handle(), pq, nullptr);
    dds_delete_qos(pq);
    check(pub, std::string("dds_create_publisher(") + topic.name() + ")");
    publisher_ = Entity(pub);
    create(pub, topic, qos);
  }

  /// Returns false (and counts) if DDS refused the sample; never throws (safe in loops).
  bool write(const T& sample) {
    const dds_return_t rc = dds_write(writer_.get(), &sample);
    if (rc < 0) {
      ++failures_;
      last_error_ = rc;
      return false;
    }
    ++written_;
    return true;
  }
  /// Tells readers this instance (robot) is gone for good.
  bool dispose(const T& key_sample) { return dds_dispose(writer_.get(), &key_sample) >= 0; }
  /// Tells readers this writer no longer writes the instance (they see "no writers").
  bool unregister(const T& key_sample) { return dds_unregister_instance(writer_.get(), &key_sample) >= 0; }

  /// Waits until at least n readers matched; false on timeout.
  bool wait_for_readers(std::uint32_t n, Nanos timeout) {
    const Nanos deadline = MonotonicClock::instance().now() + timeout;
    dds_publication_matched_status_t st{};
    for (;;) {
      check(dds_get_publication_matched_status(writer_.get(), &st), "dds_get_publication_matched_status");
      if (st.current_count >= n) return true;
      if (MonotonicClock::instance().now() >= deadline) return false;
      dds_sleepfor(DDS_MSECS(5));
    }
  }

  dds_entity_t handle() const { return writer_.get(); }
  std::uint64_t written() const { return written_; }
  std::uint64_t failures() const { return failures_; }
  dds_return_t last_error() const { return last_error_; }

 private:
  void create(dds_entity_t parent, const Topic<T>& topic, const QosSpec& qos) {
    dds_qos_t* q = make_qos(qos);
    const dds_entity_t w = dds_create_writer(parent, topic.handle(), q, nullptr);
    dds_delete_qos(q);
    check(w, std::string("dds_create_writer(") + topic.name() + ")");
    writer_ = Entity(w);
    name_ = topic.name();
  }

  Entity publisher_;  // a per-robot topic's, with the robot's partition; deleted after writer_
  Entity writer_;
  const char* name_ = "";
  std::uint64_t written_ = 0;
  std::uint64_t failures_ = 0;
  dds_return_t last_error_ = 0;
};

/// Writers of a per-robot topic for the robots a tool or test speaks for, one per robot in
/// its partition, made on first use. Allocates: a robot itself has one Writer, made at start-up.
template <typename T>
  requires PerRobotTopic<T>
class RobotWriters {
 public:
  RobotWriters(const Participant& pp, const Topic<T>& topic, const QosSpec& qos,
               std::initializer_list<std::uint16_t> robot_ids = {})
      : pp_(&pp), topic_(&topic), qos_(qos) {
    for (const std::uint16_t id : robot_ids) writer(id);
  }
  /// Robot `robot_id`'s writer.
  Writer<T>& writer(std::uint16_t robot_id) {
    std::unique_ptr<Writer<T>>& w = writers_[robot_id];
    if (!w) w = std::make_unique<Writer<T>>(*pp_, *topic_, qos_, robot_id);
    return *w;
  }
  /// Writes in the partition of the sample's own robot.
  bool write(const T& sample) { return writer(sample.robot_id).write(sample); }
  bool dispose(const T& key_sample) { return writer(key_sample.robot_id).dispose(key_sample); }
  /// Waits until every writer made so far matched at least n readers.
  bool wait_for_readers(std::uint32_t n, Nanos timeout) {
    for (auto& [id, w] : writers_) {
      if (!w->wait_for_readers(n, timeout)) return false;
    }
    return true;
  }
  std::size_t size() const { return writers_.size(); }
  bool has(std::uint16_t robot_id) const { return writers_.contains(robot_id); }

 private:
  const Participant* pp_;
  const Topic<T>* topic_;
  QosSpec qos_;
  std::map<std::uint16_t, std::unique_ptr<Writer<T>>> writers_;
};

/// What happened to an instance (robot) when a reader sees an invalid sample.
enum class InstanceEvent { kDisposed, kNoWriters };

template <typename T>
class Reader {
 public:
  /// Reads `partition` (nullptr: the default one); a per-robot topic reads every robot's.
  Reader(const Participant& pp, const Topic<T>& topic, const QosSpec& qos,
         const char* partition = PerRobotTopic<T> ? kAllRobotsPartition : nullptr) {
    dds_entity_t parent = pp.handle();
    if (partition != nullptr) {
      dds_qos_t* sq = make_partition_qos(partition);
      parent = dds_create_subscriber(pp.handle(), sq, nullptr);
      dds_delete_qos(sq);
      check(parent, std::string("dds_create_subscriber(") + topic.name() + ")");
      subscriber_ = Entity(parent);
    }
    dds_qos_t* q = make_qos(qos);
    const dds_entity_t r = dds_create_reader(parent, topic.handle(), q, nullptr);
    dds_delete_qos(q);
    check(r, std::string("dds_create_reader(") + topic.name() + ")");
    reader_ = Entity(r);
    const dds_entity_t cond = dds_create_readcondition(r, DDS_ANY_STATE);
    check(cond, "dds_create_readcondition");
    const dds_entity_t ws = dds_create_waitset(pp.handle());
    check(ws, "dds_create_waitset");
    waitset_ = Entity(ws);
    check(dds_waitset_attach(ws, cond, 0), "dds_waitset_attach");
  }

  /// Blocks until data (or an instance state change) is available or the timeout passes.
  bool wait(Nanos timeout) {
    const dds_return_t n = dds_waitset_wait(waitset_.get(), nullptr, 0, timeout);
    check(n, "dds_waitset_wait");
    return n > 0;
  }

  /// Takes everything available. on_sample(const T&, const dds_sample_info_t&) for data;
  /// on_event(const T& key_fields, InstanceEvent) when an instance is disposed or lost its writers.
  /// A per-robot topic's sample (or dispose) keyed to another robot than the one whose
  /// partition its writer is in is dropped and counted (foreign_samples), never delivered.
  template <typename OnSample, typename OnEvent>
  std::size_t take(OnSample&& on_sample, OnEvent&& on_event) {
    constexpr int kBatch = 16;
    std::size_t total = 0;
    for (;;) {
      void* samples[kBatch] = {};
      dds_sample_info_t infos[kBatch];
      const dds_return_t n = dds_take(reader_.get(), samples, infos, kBatch, kBatch);
      check(n, "dds_take");
      for (int i = 0; i < n; ++i) {
        const T& s = *static_cast<const T*>(samples[i]);
        const bool foreign = is_foreign(s, infos[i]);
        if (foreign) ++foreign_samples_;
        if (infos[i].valid_data && !foreign) {
          on_sample(s, infos[i]);
          ++total;
        }
        // A state change arrives either as an invalid sample or on the instance's
        // last data sample still unread; report it once, after that sample.
        const bool last_of_instance = [&] {
          for (int j = i + 1; j < n; ++j) {
            if (infos[j].instance_handle == infos[i].instance_handle) return false;
          }
          return true;
        }();
        if (!last_of_instance) continue;
        if (infos[i].instance_state == DDS_IST_NOT_ALIVE_DISPOSED && !foreign) {
          on_event(s, InstanceEvent::kDisposed);
        } else if (infos[i].instance_state == DDS_IST_NOT_ALIVE_NO_WRITERS) {
          on_event(s, InstanceEvent::kNoWriters);
        }
      }
      if (n > 0) dds_return_loan(reader_.get(), samples, n);
      if (n < kBatch) break;
    }
    return total;
  }

  /// Takes data only.
  template <typename OnSample>
  std::size_t take(OnSample&& on_sample) {
    return take(std::forward<OnSample>(on_sample), [](const T&, InstanceEvent) {});
  }

  dds_entity_t handle() const { return reader_.get(); }
  /// Samples dropped because their robot_id is not the robot whose partition they came from.
  std::uint64_t foreign_samples() const { return foreign_samples_; }

 private:
  bool is_foreign(const T& s, const dds_sample_info_t& info) {
    if constexpr (PerRobotTopic<T>) {
      // Data and disposes carry their writer; a "no writers" change may not (and is harmless).
      // A dispose that lands on a still unread data sample shows as that sample's state, with
      // the data's writer: it cannot be told apart (the robot's next status revives it).
      if (!info.valid_data && info.instance_state != DDS_IST_NOT_ALIVE_DISPOSED) return false;
      return writer_robots_.foreign(reader_.get(), info.publication_handle, s.robot_id);
    } else {
      (void)s;
      (void)info;
      return false;
    }
  }

  Entity subscriber_;  // when reading a partition other than the default one; deleted last
  Entity reader_;
  Entity waitset_;
  WriterRobots writer_robots_;
  std::uint64_t foreign_samples_ = 0;
};

}  // namespace cairn::dds

#include "tools/fuzz_base/fuzz_traffic.hpp"

#include <algorithm>

namespace cairn::fuzz {

namespace {

// A topic robots publish has a writer per robot id (in that robot's partition), at most this
// many per topic: the id sweep would otherwise make thousands.
constexpr std::size_t kMaxRobotWriters = 32;
// Every this many samples of a robot topic goes out in another robot's partition, as a robot
// lying about its id would: the base must drop each (its reader's foreign_samples).
constexpr std::uint64_t kMisplaceEvery = 16;

template <typename T>
struct WriterFor {
  using type = dds::Writer<T>;
};
template <dds::PerRobotTopic T>
struct WriterFor<T> {
  using type = dds::RobotWriters<T>;
};
template <typename T>
using WriterOf = typename WriterFor<T>::type;

template <typename T>
struct TopicWriter {
  dds::Topic<T> topic;
  WriterOf<T> writer;
  std::unique_ptr<T> sample = std::make_unique<T>();  // up to 3 kB: not on the stack
  explicit TopicWriter(const dds::Participant& pp) : topic(pp), writer(pp, topic, dds::latched_qos(1)) {}
};

template <typename T>
bool write_sample(dds::Writer<T>& w, const T& s, bool /*misplace*/, bool* /*misplaced*/) {
  return w.write(s);
}

/// In the sample's robot's partition, unless `misplace` or the writers are at their bound
/// and this robot has none: then in robot 1's (robot 2's for robot 1's sample).
template <typename T>
bool write_sample(dds::RobotWriters<T>& w, const T& s, bool misplace, bool* misplaced) {
  *misplaced = misplace || (!w.has(s.robot_id) && w.size() >= kMaxRobotWriters);
  if (!*misplaced) return w.write(s);
  return w.writer(s.robot_id == 1 ? 2 : 1).write(s);
}

}  // namespace

struct FuzzTraffic::Writers {
  TopicWriter<cairn_OdometryIncrement> odometry;
  TopicWriter<cairn_FeatureObservations> features;
  TopicWriter<cairn_LaserScan> scan;
  dds::RobotWriters<cairn_LaserScan> scan_best_effort;
  TopicWriter<cairn_RobotStatus> status;
  TopicWriter<cairn_Bid> bid;
  TopicWriter<cairn_VisitRequest> visit;
  explicit Writers(const dds::Participant& pp)
      : odometry(pp),
        features(pp),
        scan(pp),
        scan_best_effort(pp, scan.topic, dds::sensor_qos(1)),
        status(pp),
        bid(pp),
        visit(pp) {}
};

FuzzTraffic::FuzzTraffic(const dds::Participant& pp, MutatorConfig cfg, std::vector<Topic> topics)
    : mutator_(std::move(cfg)), rotation_(std::move(topics)), w_(std::make_unique<Writers>(pp)) {
  if (rotation_.empty()) {
    for (std::size_t t = 0; t < kTopics; ++t) rotation_.push_back(static_cast<Topic>(t));
  }
}

FuzzTraffic::~FuzzTraffic() = default;

bool FuzzTraffic::fuzzes(Topic t) const { return std::find(rotation_.begin(), rotation_.end(), t) != rotation_.end(); }

void FuzzTraffic::send_one() {
  const Topic t = rotation_[turn_ % rotation_.size()];
  const bool alternate = (turn_ / rotation_.size()) % 2 == 1;
  ++turn_;
  // Fill the topic's sample, maybe move it onto the id sweep, write it with `writer`.
  Mutation m{};
  bool ok = false;
  bool misplaced = false;
  auto emit = [&](auto& tw, auto fill, auto& writer) {
    m = (mutator_.*fill)(tw.sample.get());
    mutator_.sweep(&tw.sample->robot_id);
    ok = write_sample(writer, *tw.sample, total_ % kMisplaceEvery == kMisplaceEvery - 1, &misplaced);
  };
  switch (t) {
    case Topic::kOdometry: emit(w_->odometry, &SampleMutator::odometry, w_->odometry.writer); break;
    case Topic::kFeatures: emit(w_->features, &SampleMutator::features, w_->features.writer); break;
    case Topic::kScan: emit(w_->scan, &SampleMutator::scan, alternate ? w_->scan_best_effort : w_->scan.writer); break;
    case Topic::kStatus: emit(w_->status, &SampleMutator::status, w_->status.writer); break;
    case Topic::kBid: emit(w_->bid, &SampleMutator::bid, w_->bid.writer); break;
    case Topic::kVisit: emit(w_->visit, &SampleMutator::visit, w_->visit.writer); break;
    case Topic::kCount: return;
  }
  ++sent_[static_cast<std::size_t>(t)][static_cast<std::size_t>(m)];
  ++total_;
  refused_ += ok ? 0 : 1;
  misplaced_ += misplaced ? 1 : 0;
}

}  // namespace cairn::fuzz

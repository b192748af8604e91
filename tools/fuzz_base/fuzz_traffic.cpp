#include "tools/fuzz_base/fuzz_traffic.hpp"

#include <algorithm>

namespace cairn::fuzz {

namespace {

template <typename T>
struct TopicWriter {
  dds::Topic<T> topic;
  dds::Writer<T> writer;
  std::unique_ptr<T> sample = std::make_unique<T>();  // up to 3 kB: not on the stack
  explicit TopicWriter(const dds::Participant& pp) : topic(pp), writer(pp, topic, dds::latched_qos(1)) {}
};

}  // namespace

struct FuzzTraffic::Writers {
  TopicWriter<cairn_OdometryIncrement> odometry;
  TopicWriter<cairn_FeatureObservations> features;
  TopicWriter<cairn_LaserScan> scan;
  dds::Writer<cairn_LaserScan> scan_best_effort;
  TopicWriter<cairn_RobotStatus> status;
  TopicWriter<cairn_Bid> bid;
  explicit Writers(const dds::Participant& pp)
      : odometry(pp), features(pp), scan(pp), scan_best_effort(pp, scan.topic, dds::sensor_qos(1)), status(pp), bid(pp) {}
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
  Mutation m{};
  bool ok = false;
  switch (t) {
    case Topic::kOdometry:
      m = mutator_.odometry(w_->odometry.sample.get());
      mutator_.sweep(&w_->odometry.sample->robot_id);
      ok = w_->odometry.writer.write(*w_->odometry.sample);
      break;
    case Topic::kFeatures:
      m = mutator_.features(w_->features.sample.get());
      mutator_.sweep(&w_->features.sample->robot_id);
      ok = w_->features.writer.write(*w_->features.sample);
      break;
    case Topic::kScan:
      m = mutator_.scan(w_->scan.sample.get());
      mutator_.sweep(&w_->scan.sample->robot_id);
      ok = alternate ? w_->scan_best_effort.write(*w_->scan.sample) : w_->scan.writer.write(*w_->scan.sample);
      break;
    case Topic::kStatus:
      m = mutator_.status(w_->status.sample.get());
      mutator_.sweep(&w_->status.sample->robot_id);
      ok = w_->status.writer.write(*w_->status.sample);
      break;
    case Topic::kBid:
      m = mutator_.bid(w_->bid.sample.get());
      mutator_.sweep(&w_->bid.sample->robot_id);
      ok = w_->bid.writer.write(*w_->bid.sample);
      break;
    case Topic::kCount: return;
  }
  ++sent_[static_cast<std::size_t>(t)][static_cast<std::size_t>(m)];
  ++total_;
  refused_ += ok ? 0 : 1;
}

}  // namespace cairn::fuzz

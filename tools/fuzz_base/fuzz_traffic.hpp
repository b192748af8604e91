// cairn-fuzz-base's hostile publisher: one sample at a time, topics in turn, from the
// SampleMutator, counted per topic and mutation. Every topic has a reliable, transient-local
// writer, which offers what any reader of the base may request; scans also a best-effort one,
// as a robot's sensor writer (a best-effort writer matches no reliable reader).
#pragma once

#include <array>
#include <memory>
#include <vector>

#include "common/dds/topics.hpp"
#include "tools/fuzz_base/sample_mutator.hpp"

namespace cairn::fuzz {

inline constexpr std::size_t kTopics = static_cast<std::size_t>(Topic::kCount);
inline constexpr std::size_t kMutations = static_cast<std::size_t>(Mutation::kCount);

class FuzzTraffic {
 public:
  /// `topics` empty: all of them.
  FuzzTraffic(const dds::Participant& pp, MutatorConfig cfg, std::vector<Topic> topics);
  ~FuzzTraffic();
  void send_one();
  std::uint64_t sent(Topic t, Mutation m) const { return sent_[static_cast<std::size_t>(t)][static_cast<std::size_t>(m)]; }
  bool fuzzes(Topic t) const;
  std::uint64_t total() const { return total_; }
  std::uint64_t refused_by_writer() const { return refused_; }
  /// Robot-topic samples written in another robot's partition (the base must drop them all).
  std::uint64_t misplaced() const { return misplaced_; }

 private:
  struct Writers;
  SampleMutator mutator_;
  std::vector<Topic> rotation_;
  std::unique_ptr<Writers> w_;
  std::array<std::array<std::uint64_t, kMutations>, kTopics> sent_{};
  std::uint64_t total_ = 0, refused_ = 0, misplaced_ = 0, turn_ = 0;
};

}  // namespace cairn::fuzz

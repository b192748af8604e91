// cairn-replay's work: the messages of an MCAP recording written back into DDS, on the
// same topics with the QoS their original writers use, keeping their relative timing
// (log_time) scaled by a rate, or as fast as possible.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "common/clock.hpp"
#include "common/dds/participant.hpp"
#include "tools/mcap/mcap_reader.hpp"
#include "tools/recording/raw_topic.hpp"

namespace cairn::recording {

struct ReplayOptions {
  double rate = 1.0;                // 0 = as fast as possible
  std::set<std::string> only;       // replay only these topics (empty: all)
  std::set<std::string> exclude;    // never these
  Nanos wait_for_readers = 0;       // before the first message: until every topic replayed has min_readers, at most this
  std::uint32_t min_readers = 1;
  Nanos progress_every = 0;         // wall time between progress reports (0 = none)
};

struct ReplayResult {
  std::uint64_t written = 0, rejected = 0, skipped = 0;  // skipped: not replayed (filtered or not a Cairn cdr channel)
  bool interrupted = false;
  double wall_s = 0, recorded_s = 0;
  std::string first_error;  // of the rejected samples
};

class Replayer {
 public:
  /// Plans the replay of `rec`; creates a writer per replayed topic (throws DdsError, std::invalid_argument
  /// for a topic name in only/exclude that is not a Cairn topic).
  Replayer(const dds::Participant& pp, const mcap::Contents& rec, ReplayOptions opt);
  /// Topics replayed, and those of the file that are not (with why).
  const std::vector<std::string>& replayed_topics() const { return replayed_; }
  const std::vector<std::string>& notes() const { return notes_; }
  /// Runs to the end, or until stop() returns true. progress(line) gets the progress lines.
  ReplayResult run(const std::function<bool()>& stop, const std::function<void(const std::string&)>& progress);

 private:
  const mcap::Contents& rec_;
  ReplayOptions opt_;
  std::map<std::uint16_t, RawWriter*> by_channel_;  // channel id -> its topic's writer
  std::vector<std::unique_ptr<RawWriter>> writers_;
  std::vector<std::string> replayed_, notes_;
};

}  // namespace cairn::recording

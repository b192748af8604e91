#include "tools/recording/replayer.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

namespace cairn::recording {

Replayer::Replayer(const dds::Participant& pp, const mcap::Contents& rec, ReplayOptions opt) : rec_(rec), opt_(std::move(opt)) {
  for (const auto* names : {&opt_.only, &opt_.exclude})
    for (const std::string& n : *names)
      if (!find_topic(n)) throw std::invalid_argument("'" + n + "' is not a Cairn topic (see docs/recording.md)");
  std::map<std::string, RawWriter*> by_topic;
  for (const auto& [id, ch] : rec_.channels) {
    const TopicEntry* t = find_topic(ch.topic);
    if (!t) {
      notes_.push_back(ch.topic + ": not a Cairn topic, skipped");
      continue;
    }
    if (ch.message_encoding != "cdr") {
      notes_.push_back(ch.topic + ": message encoding '" + ch.message_encoding + "', not cdr, skipped");
      continue;
    }
    if ((!opt_.only.empty() && !opt_.only.contains(ch.topic)) || opt_.exclude.contains(ch.topic)) continue;
    RawWriter*& w = by_topic[ch.topic];
    if (!w) {
      writers_.push_back(std::make_unique<RawWriter>(pp, *t));
      w = writers_.back().get();
      replayed_.push_back(ch.topic);
    }
    by_channel_[id] = w;
  }
  // Each robot's writer of a per-robot topic now, so the wait for readers below covers it.
  for (const mcap::Message& m : rec_.messages) {
    const auto it = by_channel_.find(m.channel);
    if (it == by_channel_.end() || !it->second->topic().per_robot) continue;
    if (const std::optional<std::uint16_t> robot = cdr_robot_id(m.data)) it->second->add_robot(*robot);
  }
}

ReplayResult Replayer::run(const std::function<bool()>& stop, const std::function<void(const std::string&)>& progress) {
  ReplayResult r;
  auto& clock = MonotonicClock::instance();
  // Volatile topics reach only readers matched before the write, and a reader that joins a
  // latched topic mid-replay was seen to miss samples: wait for them first.
  const Nanos wait_end = clock.now() + opt_.wait_for_readers;
  for (;;) {
    bool all = true;
    for (const auto& w : writers_) all = all && w->matched() >= opt_.min_readers;
    if (all || clock.now() >= wait_end || stop()) break;
    clock.sleep_until(clock.now() + 10 * kNanosPerMilli);
  }
  const Nanos start = clock.now();
  Nanos next_progress = start + opt_.progress_every;
  bool have_first = false;
  std::uint64_t first_log = 0, last_log = 0;
  const std::size_t total = rec_.messages.size();
  for (std::size_t i = 0; i < total; ++i) {
    const mcap::Message& m = rec_.messages[i];
    const auto it = by_channel_.find(m.channel);
    if (it == by_channel_.end()) {
      ++r.skipped;
      continue;
    }
    if (!have_first) {
      first_log = m.log_time;
      have_first = true;
    }
    last_log = std::max(last_log, m.log_time);
    if (opt_.rate > 0 && m.log_time > first_log) {
      // Capped (31 years) so that a hostile log time cannot overflow the conversion; a wait
      // that long still ends on SIGINT.
      const double due_s = std::min(static_cast<double>(m.log_time - first_log) * 1e-9 / opt_.rate, 1e9);
      const Nanos due = start + seconds_to_nanos(due_s);
      // In slices, so a stop request is seen during a long pause in the recording.
      while (clock.now() < due && !stop()) clock.sleep_until(std::min(due, clock.now() + 100 * kNanosPerMilli));
    }
    if (stop()) {
      r.interrupted = true;
      break;
    }
    const std::string err = it->second->write(m.data);
    if (err.empty()) {
      ++r.written;
    } else {
      if (r.rejected++ == 0) r.first_error = it->second->topic().name + std::string(": ") + err;
    }
    const Nanos now = clock.now();
    if (opt_.progress_every > 0 && now >= next_progress) {
      char line[160];
      std::snprintf(line, sizeof line, "replay: %zu of %zu messages, %.1f s of the recording in %.1f s", i + 1, total,
                    static_cast<double>(last_log - first_log) * 1e-9, nanos_to_seconds(now - start));
      progress(line);
      next_progress = now + opt_.progress_every;
    }
  }
  // Reliable data still in flight reaches the readers before the writers go away.
  for (const auto& w : writers_) w->wait_for_acks(5 * kNanosPerSecond);
  r.wall_s = nanos_to_seconds(clock.now() - start);
  r.recorded_s = static_cast<double>(last_log - first_log) * 1e-9;
  return r;
}

}  // namespace cairn::recording

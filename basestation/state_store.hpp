// Crash-safe persistence of the base station's fusion state: a snapshot plus a
// write-ahead log of every input message since it. Each message is appended to the
// log before it is applied, so a restart (snapshot + replay) rebuilds the exact state
// and loses no observation. A torn last record (killed mid-write) is detected by its
// checksum, reported and ignored.
//
//   DIR/snapshot.bin     generation G, the Fusion snapshot after G-1 logs
//   DIR/log-G.bin        the messages applied since snapshot G
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include "basestation/fusion.hpp"
#include "common/clock.hpp"

namespace cairn::base {

struct RestoreReport {
  bool snapshot_loaded = false;
  std::uint64_t generation = 0;
  std::uint64_t replayed_odometry = 0, replayed_features = 0;
  std::uint64_t torn_records = 0;  // incomplete or corrupt records at the log's end (ignored)
  std::uint64_t failed_records = 0;  // records that threw when applied: skipped and counted (Reject::kApplyFailed)
};

class StateStore {
 public:
  /// `sync_every` bounds how much a power loss can cost (kill -9 loses nothing either way).
  StateStore(std::string dir, Nanos snapshot_period, Nanos sync_every = 50 * kNanosPerMilli);
  ~StateStore();
  StateStore(const StateStore&) = delete;
  StateStore& operator=(const StateStore&) = delete;

  /// Loads the snapshot (if any) into `fusion` and replays the log through it; opens the log for appending.
  RestoreReport restore(Fusion* fusion);
  void append(const msg::OdometryIncrement& m, Nanos now);
  void append(const msg::FeatureObservations& m, Nanos now);
  /// Writes a new snapshot when the period has passed (or `force`); starts a new log.
  bool maybe_snapshot(const Fusion& fusion, Nanos now, bool force = false);

  std::uint64_t generation() const { return generation_; }
  const std::string& dir() const { return dir_; }

 private:
  void open_log();
  void write_record(std::uint8_t type, const void* data, std::uint32_t size, Nanos now);
  std::string log_path(std::uint64_t gen) const;

  std::string dir_;
  Nanos snapshot_period_, sync_every_;
  Nanos last_snapshot_ = 0, last_sync_ = 0;
  std::uint64_t generation_ = 1;
  std::FILE* log_ = nullptr;
};

}  // namespace cairn::base

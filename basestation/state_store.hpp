// Crash-safe persistence of the base station's fusion state: snapshots plus a write-ahead
// log of every input message since each. Each message is appended to the log before it is
// applied, so a restart (snapshot + replay) rebuilds the exact state and loses no message
// whose append returned. Layout of DIR (docs/ccml.md, "Persistence"):
//
//   snapshot-G.bin   the Fusion state when log G began; header with a CRC-32 of the payload
//   log-G.bin        the messages applied after snapshot G; every record with its length and CRC-32
//
// The two newest snapshots are kept (with the logs from the older one on): a corrupt
// newest snapshot falls back to the previous one and both logs. A new snapshot is written
// to a temporary file, fsync'd, renamed and the directory fsync'd before anything older
// is deleted. A torn or corrupt record ends the log's replay (counted, never fatal).
//
// Every write, fsync, rename and unlink is checked. A failure (a full disk: ENOSPC, or
// EFBIG at a file-size limit) is logged, counted (PersistCounters) and never thrown: the
// fusion goes on in memory, the log is cut back to its last whole record and no longer
// appended to, and what is on disk still restores (to the last message persisted). The
// next successful snapshot (retried every period) resumes persistence.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include "basestation/fusion.hpp"
#include "common/clock.hpp"

namespace cairn::base {

struct RestoreReport {
  bool snapshot_loaded = false;
  std::uint64_t generation = 0;           // of the snapshot loaded (0: none, fresh state)
  std::uint64_t snapshots_rejected = 0;   // newer snapshots refused (bad checksum, truncated, unreadable)
  std::uint64_t logs_replayed = 0;
  std::uint64_t replayed_odometry = 0, replayed_features = 0;
  std::uint64_t torn_records = 0;  // incomplete or corrupt records ending a log (ignored with what follows)
  std::uint64_t torn_bytes = 0;    // bytes ignored after the last whole record
  std::uint64_t failed_records = 0;  // records that threw when applied: skipped and counted (Reject::kApplyFailed)
  bool snapshot_written = false;   // restore's own snapshot (false: on disk unchanged, running in memory)
};

struct PersistCounters {
  std::uint64_t records_appended = 0;
  std::uint64_t records_not_persisted = 0;  // applied in memory only (persistence suspended)
  std::uint64_t snapshots_written = 0, snapshots_failed = 0;
  std::uint64_t write_errors = 0;  // failed writes, fsyncs, renames, unlinks (each once)
  std::uint64_t disk_full = 0;     // of which ENOSPC / EFBIG / EDQUOT
};

class StateStore {
 public:
  /// File operations, for fault injection in tests (the kill test): the hook is called
  /// before each operation; for kWrite with the descriptor and the bytes about to be written.
  enum class IoOp { kLogWrite, kLogSync, kSnapshotWrite, kSnapshotSync, kRename, kDirSync, kUnlink, kLogCreate };
  using IoHook = std::function<void(IoOp, int fd, const void* data, std::size_t size)>;

  /// `sync_every` bounds how much a power loss can cost (kill -9 loses nothing either way).
  StateStore(std::string dir, Nanos snapshot_period, Nanos sync_every = 50 * kNanosPerMilli);
  ~StateStore();
  StateStore(const StateStore&) = delete;
  StateStore& operator=(const StateStore&) = delete;

  /// Loads the newest valid snapshot (if any) into `fusion`, replays the logs after it and
  /// writes a new snapshot to continue from (a fresh log: a torn tail is never appended to).
  /// Throws only if snapshots exist and none of them is usable (nothing is deleted then).
  RestoreReport restore(Fusion* fusion);
  /// Write-ahead: call before applying the message. Never throws; on failure the message
  /// is counted not persisted and persistence is suspended until the next snapshot.
  void append(const msg::OdometryIncrement& m, Nanos now);
  void append(const msg::FeatureObservations& m, Nanos now);
  /// Writes a new snapshot when the period has passed (or `force`); starts a new log.
  /// False if none was due or it failed (counted, logged, on disk unchanged).
  bool maybe_snapshot(const Fusion& fusion, Nanos now, bool force = false);

  std::uint64_t generation() const { return generation_; }
  const std::string& dir() const { return dir_; }
  /// False while messages are applied in memory only (after a failed write).
  bool persisting() const { return log_fd_ >= 0; }
  const PersistCounters& counters() const { return counters_; }
  const std::string& last_error() const { return last_error_; }
  void set_io_hook(IoHook hook) { hook_ = std::move(hook); }

 private:
  bool write_snapshot(const Fusion& fusion, std::uint64_t gen);
  bool open_log(std::uint64_t gen);
  void close_log();
  void suspend(const std::string& why);
  void write_record(std::uint8_t type, const void* data, std::uint32_t size, Nanos now);
  void remove_older_than(std::uint64_t gen);
  bool fail(const std::string& what, int err);
  std::string snapshot_path(std::uint64_t gen) const;
  std::string log_path(std::uint64_t gen) const;

  std::string dir_;
  Nanos snapshot_period_, sync_every_;
  Nanos last_snapshot_ = 0, last_sync_ = 0;
  bool clock_unset_ = false;
  std::uint64_t generation_ = 0;   // of the current log (and of the newest snapshot)
  std::uint64_t keep_from_ = 0;    // the oldest generation still needed (the previous good snapshot)
  int log_fd_ = -1;
  std::uint64_t log_size_ = 0;     // bytes of whole records in the current log
  std::uint64_t before_end_ = 0;   // its size before its last end record
  bool ends_complete_ = false;     // its last record is an end record
  PersistCounters counters_;
  std::string last_error_;
  IoHook hook_;
};

}  // namespace cairn::base

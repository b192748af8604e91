// Issue 16, item 2: persistence you can pull the plug on. The base's StateStore with the
// fusion on the synthetic fleet stream: a corrupt newest snapshot falls back to the one
// before and its logs; a torn or corrupt log tail is ignored and counted; a full disk
// (a file-size limit: EFBIG, as ENOSPC) is counted, the fusion goes on in memory and what
// is on disk still restores; a failed snapshot inside restore() changes nothing on disk;
// and the kill test: a child process running the node's persistence path is SIGKILLed at
// ten seeded points of its file operations (torn writes included), restarted from disk
// each time, and its final state is bit-identical to an uninterrupted run.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>

#include "basestation/fusion.hpp"
#include "basestation/state_store.hpp"
#include "tools/fleet_stream/fleet_scenario.hpp"

namespace cairn::base {
namespace {

namespace fs = std::filesystem;
using fleet_stream::FleetScenario;

constexpr Nanos kStep = 10 * kNanosPerMilli;  // the stream's messages are 10 ms apart for the store's clock

FusionConfig config_for(const FleetScenario& s) {
  FusionConfig c;
  for (std::size_t r = 0; r < s.starts.size(); ++r) {
    RobotPrior p;
    p.known = true;
    p.pose = s.starts[r];
    p.sigma = Vec3(0.05, 0.05, 0.01);
    c.robots[static_cast<std::uint16_t>(r + 1)] = p;
  }
  return c;
}

using fleet_stream::feed;

/// What the node does with one message: check, log (write-ahead), apply.
void accept(Fusion* f, StateStore* store, const fleet_stream::FleetMessage& m, Nanos now) {
  std::visit([&](const auto& x) {
    if (f->check(x)) return;
    store->append(x, now);
  }, m);
  feed(f, m);
}

/// The fusion after the first n messages, without any store.
Fusion reference(const FleetScenario& s, std::size_t n) {
  Fusion f(config_for(s));
  for (std::size_t k = 0; k < n && k < s.messages.size(); ++k) feed(&f, s.messages[k]);
  return f;
}

bool same_state(const Fusion& a, const Fusion& b) {
  return a.filter().mean().size() == b.filter().mean().size() && a.filter().mean() == b.filter().mean() &&
         a.filter().covariance() == b.filter().covariance() &&
         a.counters().odometry_applied == b.counters().odometry_applied &&
         a.counters().feature_messages_applied == b.counters().feature_messages_applied &&
         a.counters().observations_used == b.counters().observations_used;
}

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("cairn-" + name + "-" + std::to_string(getpid()));
  fs::remove_all(dir);
  return dir;
}

std::string contents(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::map<std::string, std::string> files_in(const fs::path& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out[e.path().filename().string()] = contents(e.path());
  return out;
}

void flip_byte(const fs::path& p, std::size_t at) {
  std::string b = contents(p);
  ASSERT_LT(at, b.size());
  b[at] = static_cast<char>(b[at] ^ 0x5A);
  std::ofstream(p, std::ios::binary | std::ios::trunc) << b;
}

/// A file-size limit for this process (writes beyond it fail with EFBIG, SIGXFSZ ignored):
/// the full disk, without privileges.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &old_);
    old_handler_ = std::signal(SIGXFSZ, SIG_IGN);
    rlimit l = old_;
    l.rlim_cur = bytes;
    ok_ = setrlimit(RLIMIT_FSIZE, &l) == 0;
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &old_);
    std::signal(SIGXFSZ, old_handler_);
  }
  bool ok() const { return ok_; }

 private:
  rlimit old_{};
  void (*old_handler_)(int) = nullptr;
  bool ok_ = false;
};

/// Feeds the stream through a store with snapshots at the given message indices; "killed" at the end (no final snapshot).
void run_with_snapshots(const FleetScenario& s, const fs::path& dir, std::size_t n, std::vector<std::size_t> snaps) {
  Fusion f(config_for(s));
  StateStore store(dir.string(), 1000 * kNanosPerSecond);
  store.restore(&f);
  for (std::size_t k = 0; k < n; ++k) {
    accept(&f, &store, s.messages[k], static_cast<Nanos>(k) * kStep);
    for (std::size_t at : snaps) {
      if (k == at) store.maybe_snapshot(f, static_cast<Nanos>(k) * kStep, true);
    }
  }
}

// ---- corrupt snapshot → the previous one and the logs after it

TEST(StateStore, CorruptNewestSnapshotFallsBackToThePreviousOneAndItsLogs) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 200);
  const std::size_t n = s.messages.size();
  const Fusion expect = reference(s, n);
  for (const bool truncate : {false, true}) {
    SCOPED_TRACE(truncate ? "truncated" : "bit flipped");
    const fs::path dir = fresh_dir("fallback");
    run_with_snapshots(s, dir, n, {n / 3, 2 * n / 3});
    // snapshot-1 (empty, at restore), -2, -3: the two newest are kept with their logs.
    ASSERT_TRUE(fs::exists(dir / "snapshot-2.bin"));
    ASSERT_TRUE(fs::exists(dir / "snapshot-3.bin"));
    ASSERT_TRUE(fs::exists(dir / "log-2.bin"));
    EXPECT_FALSE(fs::exists(dir / "snapshot-1.bin"));
    EXPECT_FALSE(fs::exists(dir / "log-1.bin"));
    const fs::path newest = dir / "snapshot-3.bin";
    if (truncate) {
      fs::resize_file(newest, fs::file_size(newest) / 2);
    } else {
      flip_byte(newest, fs::file_size(newest) / 2);  // in the middle of the covariance
    }
    Fusion f(config_for(s));
    StateStore store(dir.string(), 1000 * kNanosPerSecond);
    const RestoreReport rep = store.restore(&f);
    EXPECT_TRUE(rep.snapshot_loaded);
    EXPECT_EQ(rep.snapshots_rejected, 1u);
    EXPECT_EQ(rep.generation, 2u);
    EXPECT_EQ(rep.logs_replayed, 2u);
    EXPECT_EQ(rep.torn_records, 0u);
    EXPECT_TRUE(rep.snapshot_written);
    EXPECT_TRUE(same_state(f, expect));
    // The good snapshot and its logs are still there (the new snapshot is 4).
    EXPECT_TRUE(fs::exists(dir / "snapshot-2.bin"));
    EXPECT_TRUE(fs::exists(dir / "log-2.bin"));
    EXPECT_TRUE(fs::exists(dir / "snapshot-4.bin"));
    fs::remove_all(dir);
  }
}

TEST(StateStore, NoUsableSnapshotRefusesToStartAndChangesNothing) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(1, 60);
  const fs::path dir = fresh_dir("nosnap");
  run_with_snapshots(s, dir, s.messages.size(), {20});
  flip_byte(dir / "snapshot-1.bin", 40);
  flip_byte(dir / "snapshot-2.bin", 40);
  const auto before = files_in(dir);
  Fusion f(config_for(s));
  StateStore store(dir.string(), 1000 * kNanosPerSecond);
  try {
    store.restore(&f);
    ADD_FAILURE() << "restore accepted corrupt snapshots";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("checksum mismatch"), std::string::npos) << e.what();
  }
  EXPECT_EQ(files_in(dir), before);
  fs::remove_all(dir);
}

// ---- torn / corrupt log tail → ignored and counted

TEST(StateStore, TornOrCorruptLogTailIsIgnoredAndCounted) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(1, 50);
  const Fusion expect = reference(s, 19);
  enum Damage { kCut, kFlip, kGarbage };
  for (const Damage d : {kCut, kFlip, kGarbage}) {
    SCOPED_TRACE(d);
    const fs::path dir = fresh_dir("torn");
    std::uint64_t gen = 0;
    {
      Fusion f(config_for(s));
      StateStore store(dir.string(), 1000 * kNanosPerSecond);
      store.restore(&f);
      gen = store.generation();
      for (std::size_t k = 0; k < 20; ++k) accept(&f, &store, s.messages[k], 0);
    }
    const fs::path log = dir / ("log-" + std::to_string(gen) + ".bin");
    const auto size = fs::file_size(log);
    if (d == kCut) fs::resize_file(log, size - 7);  // killed mid-write
    if (d == kFlip) flip_byte(log, size - 30);      // the last record's payload
    if (d == kGarbage) {                            // the last record torn, then junk
      fs::resize_file(log, size - 100);
      std::ofstream(log, std::ios::binary | std::ios::app) << std::string(300, '\x7f');
    }
    Fusion f(config_for(s));
    StateStore store(dir.string(), 1000 * kNanosPerSecond);
    RestoreReport rep;
    ASSERT_NO_THROW(rep = store.restore(&f));
    EXPECT_EQ(rep.torn_records, 1u);
    EXPECT_GT(rep.torn_bytes, 0u);
    EXPECT_EQ(rep.replayed_odometry + rep.replayed_features, 19u);
    EXPECT_TRUE(same_state(f, expect));
    // Never appended to: the next restore replays the new generation, whole.
    accept(&f, &store, s.messages[19], 0);
    Fusion g(config_for(s));
    StateStore again(dir.string(), 1000 * kNanosPerSecond);
    const RestoreReport rep2 = again.restore(&g);
    EXPECT_EQ(rep2.torn_records, 0u);
    EXPECT_TRUE(same_state(g, reference(s, 20)));
    fs::remove_all(dir);
  }
}

// ---- full disk

// `end_first`: the disk fills just after the log's end record (a snapshot attempt that then
// fails): the log must lose its end record too, or a fallback would replay across the gap.
void full_disk(bool end_first) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 200);
  const std::size_t n = s.messages.size(), half = n / 2, room_again = half + 150;
  const fs::path dir = fresh_dir("fulldisk");
  Fusion f(config_for(s));
  StateStore store(dir.string(), 1000 * kNanosPerSecond, 0);
  store.restore(&f);
  for (std::size_t k = 0; k < half; ++k) {
    accept(&f, &store, s.messages[k], static_cast<Nanos>(k) * kStep);
    if (k == half - 6) {  // the log after it is smaller than a snapshot
      ASSERT_TRUE(store.maybe_snapshot(f, static_cast<Nanos>(k) * kStep, true));
    }
  }
  const std::uint64_t gen_before = store.generation();
  const fs::path log = dir / ("log-" + std::to_string(gen_before) + ".bin");
  const auto before = files_in(dir);
  {
    // A few records more fit; or the end record (25 bytes) and no message.
    FileSizeLimit full(fs::file_size(log) + (end_first ? 40 : 3000));
    ASSERT_TRUE(full.ok());
    for (std::size_t k = half; k < room_again; ++k) {
      if (end_first && k == half) {
        EXPECT_FALSE(store.maybe_snapshot(f, static_cast<Nanos>(k) * kStep, true));
      }
      accept(&f, &store, s.messages[k], static_cast<Nanos>(k) * kStep);
      if (!end_first && k == half + 100) {
        EXPECT_FALSE(store.maybe_snapshot(f, static_cast<Nanos>(k) * kStep, true));
      }
    }
  }
  const PersistCounters c = store.counters();
  EXPECT_FALSE(store.persisting());
  EXPECT_EQ(c.write_errors, 2u);  // the append that hit the limit, the snapshot; each once
  EXPECT_EQ(c.disk_full, c.write_errors);
  EXPECT_EQ(c.snapshots_failed, 1u);
  EXPECT_NE(store.last_error().find("File too large"), std::string::npos) << store.last_error();
  const std::uint64_t persisted = c.records_appended;
  EXPECT_GE(persisted, end_first ? half : half + 1);
  EXPECT_LT(persisted, end_first ? half + 1 : half + 10);
  EXPECT_EQ(persisted + c.records_not_persisted, room_again);
  // In memory nothing was lost.
  EXPECT_TRUE(same_state(f, reference(s, room_again)));
  // On disk: the snapshots untouched, the log grown by whole records only, no temporary file.
  const auto after = files_in(dir);
  ASSERT_EQ(after.size(), before.size());
  for (const auto& [name, bytes] : before) {
    ASSERT_TRUE(after.count(name)) << name;
    if (name == log.filename().string()) {
      EXPECT_EQ(after.at(name).compare(0, bytes.size(), bytes), 0);
    } else {
      EXPECT_EQ(after.at(name), bytes) << name;
    }
  }
  auto restored_copy = [&](RestoreReport* rep) {
    const fs::path copy = fresh_dir("fulldisk-copy");
    fs::copy(dir, copy);
    Fusion g(config_for(s));
    StateStore other(copy.string(), 1000 * kNanosPerSecond);
    *rep = other.restore(&g);
    fs::remove_all(copy);
    return g;
  };
  {  // ... and it restores, to the last message logged, without a torn record.
    RestoreReport rep;
    EXPECT_TRUE(same_state(restored_copy(&rep), reference(s, persisted)));
    EXPECT_EQ(rep.torn_records, 0u);
  }
  // Room again: the next snapshot resumes persistence with the whole in-memory state.
  ASSERT_TRUE(store.maybe_snapshot(f, static_cast<Nanos>(room_again) * kStep, true));
  EXPECT_TRUE(store.persisting());
  for (std::size_t k = room_again; k < n; ++k) accept(&f, &store, s.messages[k], static_cast<Nanos>(k) * kStep);
  {
    RestoreReport rep;
    EXPECT_TRUE(same_state(restored_copy(&rep), reference(s, n)));
  }
  // Were that snapshot lost, the fallback is the one before the full disk and its log,
  // which was cut short: the log after it is not replayed across the gap.
  ASSERT_EQ(store.generation(), gen_before + 1);
  flip_byte(dir / ("snapshot-" + std::to_string(gen_before + 1) + ".bin"), 100);
  RestoreReport rep;
  EXPECT_TRUE(same_state(restored_copy(&rep), reference(s, persisted)));
  EXPECT_EQ(rep.snapshots_rejected, 1u);
  EXPECT_EQ(rep.logs_replayed, 1u);
  fs::remove_all(dir);
}

TEST(StateStore, FullDiskIsCountedGoesOnInMemoryAndLeavesTheDiskRestorable) { full_disk(false); }
TEST(StateStore, FullDiskJustAfterALogsEndRecordStillLeavesTheDiskRestorable) { full_disk(true); }

TEST(StateStore, AFailedSnapshotInsideRestoreKeepsTheGoodOneAndTheLog) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(2, 100);
  const std::size_t n = s.messages.size();
  const fs::path dir = fresh_dir("restorefull");
  run_with_snapshots(s, dir, n, {n / 2});
  const auto before = files_in(dir);
  {
    FileSizeLimit full(4096);  // far smaller than a snapshot
    ASSERT_TRUE(full.ok());
    Fusion f(config_for(s));
    StateStore store(dir.string(), 1000 * kNanosPerSecond);
    RestoreReport rep;
    ASSERT_NO_THROW(rep = store.restore(&f));
    EXPECT_TRUE(rep.snapshot_loaded);
    EXPECT_FALSE(rep.snapshot_written);
    EXPECT_FALSE(store.persisting());
    EXPECT_EQ(store.counters().disk_full, 1u);
    EXPECT_TRUE(same_state(f, reference(s, n)));
    accept(&f, &store, s.messages[0], 0);  // in memory only
    EXPECT_EQ(store.counters().records_not_persisted, 1u);
  }
  EXPECT_EQ(files_in(dir), before);
  Fusion f(config_for(s));
  StateStore store(dir.string(), 1000 * kNanosPerSecond);
  EXPECT_TRUE(store.restore(&f).snapshot_written);
  EXPECT_TRUE(same_state(f, reference(s, n)));
  fs::remove_all(dir);
}

// ---- the kill test

struct KillPoint {
  std::size_t arm_at = 0;  // counting from this message on (at or before the start: from the restore on)
  StateStore::IoOp op = StateStore::IoOp::kLogWrite;
  int nth = 0;            // killed before the nth operation of this kind in the run (0: never)
  std::uint64_t torn = 0;  // for writes: this seed decides how much of it reaches the file first
};

const char* op_name(StateStore::IoOp op) {
  switch (op) {
    case StateStore::IoOp::kLogWrite: return "log write";
    case StateStore::IoOp::kLogSync: return "log fdatasync";
    case StateStore::IoOp::kSnapshotWrite: return "snapshot write";
    case StateStore::IoOp::kSnapshotSync: return "snapshot fsync";
    case StateStore::IoOp::kRename: return "rename";
    case StateStore::IoOp::kDirSync: return "directory fsync";
    case StateStore::IoOp::kUnlink: return "unlink";
    case StateStore::IoOp::kLogCreate: return "log create";
  }
  return "?";
}

constexpr Nanos kKillSnapshotPeriod = 100 * kStep;  // a snapshot every 100 messages
constexpr Nanos kKillSyncEvery = 20 * kStep;

/// The child: the node's persistence path from message `start` on, acknowledging each
/// message on `ack` once append() has returned; SIGKILLs itself at `kill`.
[[noreturn]] void child(const FleetScenario& s, const std::string& dir, std::size_t start, KillPoint kill, int ack) {
  int seen = 0;
  bool armed = kill.arm_at <= start;
  Fusion f(config_for(s));
  StateStore store(dir, kKillSnapshotPeriod, kKillSyncEvery);
  store.set_io_hook([&](StateStore::IoOp op, int fd, const void* data, std::size_t size) {
    if (!armed || op != kill.op || ++seen != kill.nth) return;
    if (fd >= 0 && data != nullptr && size > 0) {  // a torn write: a seeded prefix reaches the file
      const std::size_t part = static_cast<std::size_t>(kill.torn % size);
      if (::write(fd, data, part) < 0) _exit(3);
    }
    ::kill(getpid(), SIGKILL);
  });
  try {
    store.restore(&f);
    for (std::size_t k = start; k < s.messages.size(); ++k) {
      const Nanos now = static_cast<Nanos>(k) * kStep;
      armed = armed || k >= kill.arm_at;
      accept(&f, &store, s.messages[k], now);  // logged (returned), then applied
      const std::uint64_t k64 = k;
      if (::write(ack, &k64, sizeof k64) != sizeof k64) _exit(4);
      store.maybe_snapshot(f, now);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "child: %s\n", e.what());
    _exit(2);
  }
  _exit(store.persisting() ? 0 : 5);
}

struct ChildResult {
  int status = 0;
  long long last_ack = -1;
};

ChildResult run_child(const FleetScenario& s, const fs::path& dir, std::size_t start, KillPoint kill) {
  int p[2];
  if (pipe(p) != 0) return {-1, -1};
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    ::close(p[0]);
    child(s, dir.string(), start, kill, p[1]);
  }
  ::close(p[1]);
  ChildResult r;
  std::uint64_t k = 0;
  while (::read(p[0], &k, sizeof k) == sizeof k) r.last_ack = static_cast<long long>(k);
  ::close(p[0]);
  waitpid(pid, &r.status, 0);
  return r;
}

TEST(StateStore, KilledTenTimesAtRandomPointsEndsBitIdenticalToAnUninterruptedRun) {
  const FleetScenario s = fleet_stream::make_fleet_scenario(3, 600);  // 1800 odometry + 900 feature messages
  const std::size_t n = s.messages.size();
  const fs::path dir = fresh_dir("kill");
  const StateStore::IoOp ops[] = {StateStore::IoOp::kLogWrite, StateStore::IoOp::kLogSync, StateStore::IoOp::kSnapshotWrite,
                                  StateStore::IoOp::kSnapshotSync, StateStore::IoOp::kRename, StateStore::IoOp::kDirSync,
                                  StateStore::IoOp::kUnlink, StateStore::IoOp::kLogCreate};
  std::size_t next = 0;  // the first message the robots have not had acknowledged
  std::uint64_t torn_seen = 0, fallbacks_seen = 0, ignored_bytes = 0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    std::mt19937_64 rng(seed);
    KillPoint kill;
    // Spread over the run: the kill is armed somewhere in the seed's twelfth of the stream
    // (or at once, then often inside restore()), then hits the nth operation of its kind.
    kill.arm_at = rng() % 4 == 0 ? 0 : (seed - 1) * n / 12 + rng() % (n / 12);
    kill.op = ops[rng() % std::size(ops)];
    kill.nth = 1 + static_cast<int>(rng() % (kill.op == StateStore::IoOp::kLogWrite ? 100 : 3));
    kill.torn = rng();
    const ChildResult r = run_child(s, dir, next, kill);
    SCOPED_TRACE("seed " + std::to_string(seed) + ": killed before " + op_name(kill.op) + " #" + std::to_string(kill.nth));
    ASSERT_TRUE(WIFSIGNALED(r.status) && WTERMSIG(r.status) == SIGKILL) << "status " << r.status << " (not killed: move the point)";
    if (r.last_ack >= 0) next = static_cast<std::size_t>(r.last_ack) + 1;
    // What is on disk now holds every acknowledged message (and at most the one being logged).
    const fs::path copy = fresh_dir("kill-copy");
    fs::copy(dir, copy);
    Fusion f(config_for(s));
    StateStore store(copy.string(), kKillSnapshotPeriod);
    RestoreReport rep;
    ASSERT_NO_THROW(rep = store.restore(&f));
    torn_seen += rep.torn_records;
    fallbacks_seen += rep.snapshots_rejected;
    ignored_bytes += rep.torn_bytes;
    EXPECT_TRUE(same_state(f, reference(s, next)) || same_state(f, reference(s, next + 1)))
        << "restored " << f.counters().odometry_applied + f.counters().feature_messages_applied << " messages, "
        << next << " acknowledged";
    fs::remove_all(copy);
    std::printf("[ kill %2llu ] armed at %4zu, before %-15s #%-3d: %5zu messages acknowledged, restore: snapshot %llu, %llu log(s), %llu torn\n",
                static_cast<unsigned long long>(seed), kill.arm_at, op_name(kill.op), kill.nth, next,
                static_cast<unsigned long long>(rep.generation), static_cast<unsigned long long>(rep.logs_replayed),
                static_cast<unsigned long long>(rep.torn_records));
  }
  ASSERT_LT(next, n) << "the kills should interrupt the run, not follow it";
  const ChildResult last = run_child(s, dir, next, {});
  ASSERT_TRUE(WIFEXITED(last.status) && WEXITSTATUS(last.status) == 0) << "status " << last.status;
  ASSERT_EQ(last.last_ack, static_cast<long long>(n - 1));
  Fusion f(config_for(s));
  StateStore store(dir.string(), kKillSnapshotPeriod);
  const RestoreReport rep = store.restore(&f);
  const Fusion uninterrupted = reference(s, n);
  EXPECT_TRUE(same_state(f, uninterrupted));
  EXPECT_EQ(f.filter().mean(), uninterrupted.filter().mean());
  EXPECT_EQ(f.filter().covariance(), uninterrupted.filter().covariance());
  std::printf("[ kills    ] 10 kills, %llu torn record(s) (%llu bytes) ignored, %llu snapshot fallback(s); final state "
              "of %zu messages bit-identical: %s\n",
              static_cast<unsigned long long>(torn_seen), static_cast<unsigned long long>(ignored_bytes),
              static_cast<unsigned long long>(fallbacks_seen), n, same_state(f, uninterrupted) ? "yes" : "NO");
  (void)rep;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cairn::base

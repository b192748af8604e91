#include "basestation/state_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "common/log.hpp"

namespace cairn::base {

namespace {

namespace fs = std::filesystem;

// Snapshot: header (32 bytes) + payload (Fusion::save).
//   magic "CAIRNSNP" | u32 format | u32 crc32 | u64 generation | u64 payload size
// The CRC-32 (zlib) covers generation, payload size and payload.
constexpr char kSnapMagic[8] = {'C', 'A', 'I', 'R', 'N', 'S', 'N', 'P'};
constexpr std::size_t kSnapHeader = 32;
// Log: header (32 bytes) + records.
//   magic "CAIRNLOG" | u32 format | u32 sizeof(OdometryIncrement) | u32 sizeof(FeatureObservations) | u32 0 | u64 generation
// Record: u32 payload size | u8 type | i64 time | payload | u32 crc32 (of everything before it in the record).
constexpr char kLogMagic[8] = {'C', 'A', 'I', 'R', 'N', 'L', 'O', 'G'};
constexpr std::size_t kLogHeader = 32;
constexpr std::size_t kRecordHead = 13, kRecordTail = 4;
constexpr std::uint32_t kFormat = 2;  // 1: the unchecked snapshot.bin of earlier versions
constexpr std::uint8_t kOdometry = 1, kFeatures = 2;
constexpr std::uint8_t kEnd = 3;  // the log was complete when the next snapshot was taken (payload: u64 next generation)
constexpr std::uint32_t kMaxRecord = 1u << 20;

std::uint32_t crc(const char* data, std::size_t n) {
  return static_cast<std::uint32_t>(crc32_z(crc32_z(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(data), n));
}

template <typename T>
void put(std::string* b, const T& v) {
  b->append(reinterpret_cast<const char*>(&v), sizeof v);
}
template <typename T>
T get(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

/// 0 or the errno of the failed write (a short write at a size limit retries and gets it).
int write_all(int fd, const char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    if (w == 0) return EIO;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return 0;
}

bool disk_full(int err) { return err == ENOSPC || err == EFBIG || err == EDQUOT; }

/// Generation from "prefix-N.suffix", or 0.
std::uint64_t generation_of(const std::string& name, const char* prefix, const char* suffix) {
  const std::size_t lp = std::strlen(prefix), ls = std::strlen(suffix);
  if (name.size() <= lp + ls || name.compare(0, lp, prefix) != 0 || name.compare(name.size() - ls, ls, suffix) != 0) return 0;
  const std::string digits = name.substr(lp, name.size() - lp - ls);
  if (digits.empty() || !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) return 0;
  return std::stoull(digits);
}

bool read_file(const std::string& path, std::string* out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  out->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return !in.bad();
}

/// Checks a snapshot file; the payload or why it is refused.
bool check_snapshot(const std::string& bytes, std::uint64_t gen, std::string* payload, std::string* why) {
  if (bytes.size() < kSnapHeader) return *why = "truncated header", false;
  if (std::memcmp(bytes.data(), kSnapMagic, 8) != 0) return *why = "not a cairn-base snapshot", false;
  if (get<std::uint32_t>(bytes.data() + 8) != kFormat) return *why = "written by another version (format)", false;
  const auto size = get<std::uint64_t>(bytes.data() + 24);
  if (size != bytes.size() - kSnapHeader) return *why = "truncated (" + std::to_string(bytes.size()) + " bytes)", false;
  if (get<std::uint32_t>(bytes.data() + 12) != crc(bytes.data() + 16, bytes.size() - 16)) return *why = "checksum mismatch", false;
  if (get<std::uint64_t>(bytes.data() + 16) != gen) return *why = "generation does not match its name", false;
  payload->assign(bytes, kSnapHeader, std::string::npos);
  return true;
}

}  // namespace

StateStore::StateStore(std::string dir, Nanos snapshot_period, Nanos sync_every)
    : dir_(std::move(dir)), snapshot_period_(snapshot_period), sync_every_(sync_every) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw std::runtime_error("state store: cannot create " + dir_ + ": " + ec.message());
}

StateStore::~StateStore() { close_log(); }

std::string StateStore::snapshot_path(std::uint64_t gen) const { return dir_ + "/snapshot-" + std::to_string(gen) + ".bin"; }
std::string StateStore::log_path(std::uint64_t gen) const { return dir_ + "/log-" + std::to_string(gen) + ".bin"; }

bool StateStore::fail(const std::string& what, int err) {
  last_error_ = what + ": " + std::strerror(err);
  ++counters_.write_errors;
  if (disk_full(err)) ++counters_.disk_full;
  CAIRN_LOG_ERROR("base", "state store: {}", last_error_.c_str());
  return false;
}

void StateStore::close_log() {
  if (log_fd_ >= 0) ::close(log_fd_);  // written data is in the kernel already; close reports nothing more for it
  log_fd_ = -1;
}

void StateStore::suspend(const std::string& why) {
  // Cut back to the last whole record, so the log on disk stays clean (shrinking works on a
  // full disk), and before an end record: what follows is not logged, so the log is no
  // longer complete and a fallback must not replay the next one after it.
  if (log_fd_ >= 0 && ::ftruncate(log_fd_, static_cast<off_t>(ends_complete_ ? before_end_ : log_size_)) != 0) {
    fail("cannot cut back " + log_path(generation_), errno);
  }
  close_log();
  CAIRN_LOG_ERROR("base", "state store: persistence suspended ({}): the fusion goes on in memory, on disk stays the state up to "
                  "the last message logged; the next snapshot retries", why.c_str());
}

RestoreReport StateStore::restore(Fusion* fusion) {
  RestoreReport rep;
  close_log();
  // What is in the directory. Temporary files are leftovers of an interrupted snapshot.
  std::vector<std::uint64_t> snapshots;
  std::map<std::uint64_t, bool> logs;
  std::uint64_t newest = 0;
  for (const auto& e : fs::directory_iterator(dir_)) {
    const std::string name = e.path().filename().string();
    if (name == "snapshot.bin") {
      throw std::runtime_error("state store: " + dir_ + "/snapshot.bin was written by an older cairn-base (unchecked format 1); "
                               "move " + dir_ + " away to start afresh");
    }
    if (const auto g = generation_of(name, "snapshot-", ".bin")) snapshots.push_back(g), newest = std::max(newest, g);
    if (const auto g = generation_of(name, "log-", ".bin")) logs[g] = true, newest = std::max(newest, g);
    if (generation_of(name, "snapshot-", ".tmp")) {
      if (::unlink(e.path().c_str()) != 0) fail("cannot remove " + e.path().string(), errno);
    }
  }
  std::sort(snapshots.rbegin(), snapshots.rend());

  // The newest snapshot that checks out; a refused one falls back to the one before.
  const Fusion initial = *fusion;
  std::string refused;
  std::uint64_t base = 0;
  for (std::uint64_t g : snapshots) {
    std::string bytes, payload, why;
    if (!read_file(snapshot_path(g), &bytes)) {
      why = "unreadable";
    } else if (check_snapshot(bytes, g, &payload, &why)) {
      try {
        std::istringstream in(payload);
        fusion->load(in);
        base = g;
        break;
      } catch (const std::exception& ex) {
        why = ex.what();
        *fusion = initial;
      }
    }
    ++rep.snapshots_rejected;
    refused += " snapshot-" + std::to_string(g) + ".bin: " + why + ";";
    CAIRN_LOG_ERROR("base", "state store: {}/snapshot-{}.bin refused ({}), falling back to the previous one", dir_.c_str(), g,
                    why.c_str());
  }
  if (!snapshots.empty() && base == 0) {
    throw std::runtime_error("state store: no usable snapshot in " + dir_ + ":" + refused +
                             " nothing was changed; move the directory away to start afresh");
  }
  if (snapshots.empty() && !logs.empty()) {
    throw std::runtime_error("state store: " + dir_ + " holds logs but no snapshot to replay them from; move the directory "
                             "away to start afresh");
  }
  rep.snapshot_loaded = base != 0;
  rep.generation = base;

  // Replay the logs from the snapshot on, while each one is complete.
  for (std::uint64_t g = base; base != 0 && logs.count(g); ++g) {
    std::string b;
    if (!read_file(log_path(g), &b)) throw std::runtime_error("state store: cannot read " + log_path(g));
    ++rep.logs_replayed;
    if (b.size() < kLogHeader || std::memcmp(b.data(), kLogMagic, 8) != 0 || get<std::uint32_t>(b.data() + 8) != kFormat ||
        get<std::uint64_t>(b.data() + 24) != g) {
      if (b.size() >= kLogHeader && std::memcmp(b.data(), kLogMagic, 8) == 0 && get<std::uint32_t>(b.data() + 8) != kFormat) {
        throw std::runtime_error(log_path(g) + ": written by another version of cairn-base");
      }
      ++rep.torn_records;  // created but its header never made it: nothing in it
      rep.torn_bytes += b.size();
      break;
    }
    if (get<std::uint32_t>(b.data() + 12) != sizeof(msg::OdometryIncrement) ||
        get<std::uint32_t>(b.data() + 16) != sizeof(msg::FeatureObservations)) {
      throw std::runtime_error(log_path(g) + ": written by another version of cairn-base");
    }
    std::size_t at = kLogHeader;
    bool ended = false;
    while (at < b.size()) {
      const std::size_t left = b.size() - at;
      const char* r = b.data() + at;
      const std::uint32_t size = left >= 4 ? get<std::uint32_t>(r) : 0;
      if (left < kRecordHead + kRecordTail || size > kMaxRecord || left < kRecordHead + size + kRecordTail ||
          get<std::uint32_t>(r + kRecordHead + size) != crc(r, kRecordHead + size)) {
        ++rep.torn_records;
        rep.torn_bytes += left;
        CAIRN_LOG_WARN("base", "state store: {}: {} byte(s) after the last whole record ignored (torn or corrupt)",
                       log_path(g).c_str(), static_cast<std::uint64_t>(left));
        break;
      }
      at += kRecordHead + size + kRecordTail;
      const std::uint8_t type = static_cast<std::uint8_t>(r[4]);
      const char* data = r + kRecordHead;
      ended = type == kEnd;
      // A logged message that throws is skipped and counted: a restart must never die on
      // its own log (every restart would replay it again).
      auto apply = [&](auto&& fn) {
        try {
          fn();
        } catch (const std::exception&) {
          fusion->count(Reject::kApplyFailed);
          ++rep.failed_records;
        }
      };
      if (type == kOdometry && size == sizeof(msg::OdometryIncrement)) {
        msg::OdometryIncrement m;
        std::memcpy(&m, data, size);
        apply([&] { fusion->on_odometry(m); });
        ++rep.replayed_odometry;
      } else if (type == kFeatures && size == sizeof(msg::FeatureObservations)) {
        msg::FeatureObservations m;
        std::memcpy(&m, data, size);
        apply([&] { fusion->on_features(m); });
        ++rep.replayed_features;
      } else if (type != kEnd) {
        ++rep.torn_records;  // well-formed but unknown: stop here
        rep.torn_bytes += b.size() - at + kRecordHead + size + kRecordTail;
        break;
      }
    }
    // A log that was cut short (persistence suspended, torn) cannot be continued by the next one.
    if (!ended && logs.count(g + 1)) {
      CAIRN_LOG_WARN("base", "state store: {} incomplete: the later logs are not replayed", log_path(g).c_str());
      break;
    }
  }

  // Continue in a fresh generation, so a torn tail is never appended to. Until its
  // snapshot is durable nothing on disk is touched; if it fails, the fusion runs in memory.
  generation_ = newest;
  keep_from_ = base;
  rep.snapshot_written = maybe_snapshot(*fusion, 0, true);
  clock_unset_ = true;  // the period runs from the first call after this one (restore has no clock)
  return rep;
}

bool StateStore::open_log(std::uint64_t gen) {
  close_log();
  const std::string path = log_path(gen);
  if (hook_) hook_(IoOp::kLogCreate, -1, nullptr, 0);
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return fail("cannot create " + path, errno);
  std::string h(kLogMagic, 8);
  put(&h, kFormat);
  put(&h, static_cast<std::uint32_t>(sizeof(msg::OdometryIncrement)));
  put(&h, static_cast<std::uint32_t>(sizeof(msg::FeatureObservations)));
  put(&h, std::uint32_t{0});
  put(&h, gen);
  if (hook_) hook_(IoOp::kLogWrite, fd, h.data(), h.size());
  if (const int err = write_all(fd, h.data(), h.size())) {
    ::close(fd);
    ::unlink(path.c_str());
    return fail("cannot write " + path, err);
  }
  log_fd_ = fd;
  log_size_ = h.size();
  ends_complete_ = false;
  return true;
}

void StateStore::write_record(std::uint8_t type, const void* data, std::uint32_t size, Nanos now) {
  if (log_fd_ < 0) {
    ++counters_.records_not_persisted;
    return;
  }
  std::string rec;
  rec.reserve(kRecordHead + size + kRecordTail);
  put(&rec, size);
  put(&rec, type);
  put(&rec, static_cast<std::int64_t>(now));
  rec.append(static_cast<const char*>(data), size);
  put(&rec, crc(rec.data(), rec.size()));
  // One write per record: a process killed mid-record leaves a tail the checksum rejects.
  if (hook_) hook_(IoOp::kLogWrite, log_fd_, rec.data(), rec.size());
  if (const int err = write_all(log_fd_, rec.data(), rec.size())) {
    fail("cannot append to " + log_path(generation_), err);
    if (type != kEnd) ++counters_.records_not_persisted;
    suspend(last_error_);
    return;
  }
  if (type == kEnd) before_end_ = log_size_;
  ends_complete_ = type == kEnd;
  log_size_ += rec.size();
  if (type != kEnd) ++counters_.records_appended;
  if (now - last_sync_ >= sync_every_) {  // on the disk: bounds what a power loss can cost
    last_sync_ = now;
    if (hook_) hook_(IoOp::kLogSync, log_fd_, nullptr, 0);
    if (::fdatasync(log_fd_) != 0) {
      fail("cannot sync " + log_path(generation_), errno);
      suspend(last_error_);
    }
  }
}

void StateStore::append(const msg::OdometryIncrement& m, Nanos now) { write_record(kOdometry, &m, sizeof m, now); }
void StateStore::append(const msg::FeatureObservations& m, Nanos now) { write_record(kFeatures, &m, sizeof m, now); }

bool StateStore::write_snapshot(const Fusion& fusion, std::uint64_t gen) {
  std::ostringstream payload;
  fusion.save(payload);
  const std::string p = std::move(payload).str();
  std::string b(kSnapMagic, 8);
  put(&b, kFormat);
  put(&b, std::uint32_t{0});  // the CRC, below
  put(&b, gen);
  put(&b, static_cast<std::uint64_t>(p.size()));
  b += p;
  const std::uint32_t sum = crc(b.data() + 16, b.size() - 16);
  std::memcpy(b.data() + 12, &sum, 4);

  const std::string tmp = dir_ + "/snapshot-" + std::to_string(gen) + ".tmp", path = snapshot_path(gen);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return fail("cannot create " + tmp, errno);
  auto abandon = [&](const std::string& what, int err) {
    if (fd >= 0) ::close(fd);
    ::unlink(tmp.c_str());
    return fail(what, err);
  };
  if (hook_) hook_(IoOp::kSnapshotWrite, fd, b.data(), b.size());
  if (const int err = write_all(fd, b.data(), b.size())) return abandon("cannot write " + tmp, err);
  if (hook_) hook_(IoOp::kSnapshotSync, fd, nullptr, 0);
  if (::fsync(fd) != 0) return abandon("cannot sync " + tmp, errno);
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return fail("cannot close " + tmp, err);
  }
  if (hook_) hook_(IoOp::kRename, -1, nullptr, 0);
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return fail("cannot rename " + tmp + " to " + path, err);
  }
  return true;
}

void StateStore::remove_older_than(std::uint64_t gen) {
  std::vector<std::string> old;
  for (const auto& e : fs::directory_iterator(dir_)) {
    const std::string name = e.path().filename().string();
    std::uint64_t g = generation_of(name, "snapshot-", ".bin");
    if (!g) g = generation_of(name, "log-", ".bin");
    if (g && g < gen) old.push_back(e.path().string());
  }
  // Logs first: a snapshot is never left without the logs that continue it.
  std::sort(old.begin(), old.end(), [](const std::string& a, const std::string& b) {
    return (a.find("/log-") != std::string::npos) > (b.find("/log-") != std::string::npos);
  });
  for (const std::string& path : old) {
    if (hook_) hook_(IoOp::kUnlink, -1, nullptr, 0);
    if (::unlink(path.c_str()) != 0 && errno != ENOENT) fail("cannot remove " + path, errno);
  }
}

bool StateStore::maybe_snapshot(const Fusion& fusion, Nanos now, bool force) {
  if (!force && clock_unset_ && log_fd_ >= 0) {  // restore's snapshot was just written
    clock_unset_ = false;
    last_snapshot_ = now;
    return false;
  }
  clock_unset_ = false;
  if (!force && now - last_snapshot_ < snapshot_period_) return false;
  last_snapshot_ = now;
  const std::uint64_t gen = generation_ + 1;
  if (log_fd_ >= 0) {
    // Mark the current log complete and make it durable: a fallback to the previous
    // snapshot replays it and then the next one.
    write_record(kEnd, &gen, sizeof gen, now);
    if (log_fd_ >= 0) {
      if (hook_) hook_(IoOp::kLogSync, log_fd_, nullptr, 0);
      if (::fdatasync(log_fd_) != 0) {
        fail("cannot sync " + log_path(generation_), errno);
        suspend(last_error_);
      }
    }
  }
  if (!write_snapshot(fusion, gen)) {
    ++counters_.snapshots_failed;
    return false;  // on disk unchanged; the current log (if any) goes on
  }
  ++counters_.snapshots_written;
  generation_ = gen;
  const bool was_suspended = log_fd_ < 0;
  if (open_log(gen) && was_suspended && counters_.write_errors > 0) {
    CAIRN_LOG_INFO("base", "state store: persistence resumed with {}", snapshot_path(gen).c_str());
  }
  // The rename (and the new log) are durable once the directory is; only then may anything older go.
  bool durable = true;
  if (hook_) hook_(IoOp::kDirSync, -1, nullptr, 0);
  const int dfd = ::open(dir_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0 || ::fsync(dfd) != 0) durable = fail("cannot sync the directory " + dir_, errno);
  if (dfd >= 0) ::close(dfd);
  if (durable) {
    remove_older_than(keep_from_);  // keeps the previous good snapshot and the logs after it
    keep_from_ = gen;
  }
  return true;
}

}  // namespace cairn::base

#include "basestation/state_store.hpp"

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace cairn::base {

namespace {

constexpr std::uint8_t kOdometry = 1, kFeatures = 2;
constexpr char kLogMagic[8] = {'C', 'A', 'I', 'R', 'N', 'L', 'O', 'G'};

std::uint32_t fnv1a(const void* data, std::size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint32_t h = 2166136261u;
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 16777619u;
  return h;
}

void fsync_file(const std::string& path) {
  if (std::FILE* f = std::fopen(path.c_str(), "rb")) {
    fsync(fileno(f));
    std::fclose(f);
  }
}

}  // namespace

StateStore::StateStore(std::string dir, Nanos snapshot_period, Nanos sync_every)
    : dir_(std::move(dir)), snapshot_period_(snapshot_period), sync_every_(sync_every) {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec) throw std::runtime_error("state store: cannot create " + dir_ + ": " + ec.message());
}

StateStore::~StateStore() {
  if (log_) std::fclose(log_);
}

std::string StateStore::log_path(std::uint64_t gen) const { return dir_ + "/log-" + std::to_string(gen) + ".bin"; }

RestoreReport StateStore::restore(Fusion* fusion) {
  RestoreReport rep;
  const std::string snap = dir_ + "/snapshot.bin";
  if (std::filesystem::exists(snap)) {
    std::ifstream in(snap, std::ios::binary);
    std::uint64_t gen = 0;
    if (!in.read(reinterpret_cast<char*>(&gen), sizeof gen)) throw std::runtime_error(snap + ": truncated");
    fusion->load(in);
    generation_ = gen;
    rep.snapshot_loaded = true;
  }
  rep.generation = generation_;
  // Replay the log of this generation.
  std::ifstream log(log_path(generation_), std::ios::binary);
  if (log) {
    char magic[8];
    std::uint32_t sizes[2];
    if (log.read(magic, 8) && std::memcmp(magic, kLogMagic, 8) == 0 && log.read(reinterpret_cast<char*>(sizes), sizeof sizes)) {
      if (sizes[0] != sizeof(msg::OdometryIncrement) || sizes[1] != sizeof(msg::FeatureObservations)) {
        throw std::runtime_error(log_path(generation_) + ": written by another version of cairn-base");
      }
      std::vector<char> buf;
      for (;;) {
        std::uint8_t type = 0;
        std::uint32_t size = 0, sum = 0;
        std::int64_t t = 0;
        if (!log.read(reinterpret_cast<char*>(&type), 1)) break;
        if (!log.read(reinterpret_cast<char*>(&size), 4) || !log.read(reinterpret_cast<char*>(&t), 8) ||
            size > (1u << 20)) {
          ++rep.torn_records;
          break;
        }
        buf.resize(size);
        if (!log.read(buf.data(), size) || !log.read(reinterpret_cast<char*>(&sum), 4) || sum != fnv1a(buf.data(), size)) {
          ++rep.torn_records;
          break;
        }
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
          std::memcpy(&m, buf.data(), size);
          apply([&] { fusion->on_odometry(m); });
          ++rep.replayed_odometry;
        } else if (type == kFeatures && size == sizeof(msg::FeatureObservations)) {
          msg::FeatureObservations m;
          std::memcpy(&m, buf.data(), size);
          apply([&] { fusion->on_features(m); });
          ++rep.replayed_features;
        } else {
          ++rep.torn_records;
          break;
        }
      }
    } else {
      ++rep.torn_records;
    }
  }
  // Continue in a fresh generation so a torn tail is never appended to.
  std::ofstream out(dir_ + "/snapshot.tmp", std::ios::binary | std::ios::trunc);
  generation_ += 1;
  const std::uint64_t gen = generation_;
  out.write(reinterpret_cast<const char*>(&gen), sizeof gen);
  fusion->save(out);
  out.close();
  fsync_file(dir_ + "/snapshot.tmp");
  std::filesystem::rename(dir_ + "/snapshot.tmp", snap);
  std::filesystem::remove(log_path(gen - 1));
  open_log();
  return rep;
}

void StateStore::open_log() {
  if (log_) std::fclose(log_);
  log_ = std::fopen(log_path(generation_).c_str(), "wb");
  if (!log_) throw std::runtime_error("state store: cannot write " + log_path(generation_) + ": " + std::strerror(errno));
  const std::uint32_t sizes[2] = {sizeof(msg::OdometryIncrement), sizeof(msg::FeatureObservations)};
  std::fwrite(kLogMagic, 1, 8, log_);
  std::fwrite(sizes, sizeof sizes, 1, log_);
  std::fflush(log_);
}

void StateStore::write_record(std::uint8_t type, const void* data, std::uint32_t size, Nanos now) {
  if (!log_) open_log();
  const std::int64_t t = now;
  const std::uint32_t sum = fnv1a(data, size);
  std::fwrite(&type, 1, 1, log_);
  std::fwrite(&size, 4, 1, log_);
  std::fwrite(&t, 8, 1, log_);
  std::fwrite(data, 1, size, log_);
  std::fwrite(&sum, 4, 1, log_);
  std::fflush(log_);  // in the kernel now: survives the process being killed
  if (now - last_sync_ >= sync_every_) {
    fdatasync(fileno(log_));  // on the disk: bounds what a power loss can cost
    last_sync_ = now;
  }
}

void StateStore::append(const msg::OdometryIncrement& m, Nanos now) { write_record(kOdometry, &m, sizeof m, now); }
void StateStore::append(const msg::FeatureObservations& m, Nanos now) { write_record(kFeatures, &m, sizeof m, now); }

bool StateStore::maybe_snapshot(const Fusion& fusion, Nanos now, bool force) {
  if (!force && now - last_snapshot_ < snapshot_period_) return false;
  last_snapshot_ = now;
  const std::uint64_t gen = generation_ + 1;
  {
    std::ofstream out(dir_ + "/snapshot.tmp", std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(&gen), sizeof gen);
    fusion.save(out);
    if (!out) throw std::runtime_error("state store: cannot write " + dir_ + "/snapshot.tmp");
  }
  fsync_file(dir_ + "/snapshot.tmp");
  std::filesystem::rename(dir_ + "/snapshot.tmp", dir_ + "/snapshot.bin");
  const std::uint64_t old = generation_;
  generation_ = gen;
  open_log();
  std::filesystem::remove(log_path(old));
  return true;
}

}  // namespace cairn::base

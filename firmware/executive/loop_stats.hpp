// RT loop period statistics without allocation: mean, p99 from a fixed histogram
// (10 µs bins up to 100 ms), maximum jitter, deadline misses and when the first few
// happened (so a test can tell a miss of Cairn's from time the platform took away).
#pragma once

#include <array>
#include <cstdint>

#include "common/clock.hpp"

namespace cairn::firmware {

class LoopStats {
 public:
  explicit LoopStats(Nanos period) : period_(period) {}
  /// One wake-up at `now`; `finished` is when the cycle's work ended.
  void record(Nanos wake, Nanos deadline, Nanos finished) {
    if (last_wake_ > 0) {
      const Nanos p = wake - last_wake_;
      sum_ += p;
      ++n_;
      const auto bin = static_cast<std::size_t>(std::max<Nanos>(0, p) / kBin);
      ++hist_[bin < hist_.size() ? bin : hist_.size() - 1];
      const Nanos jitter = p > period_ ? p - period_ : period_ - p;
      if (jitter > max_jitter_) max_jitter_ = jitter;
    }
    if (finished > deadline + period_) {
      if (misses_ < miss_log_.size()) miss_log_[static_cast<std::size_t>(misses_)] = {deadline, finished};
      ++misses_;
    }
    last_wake_ = wake;
    ++cycles_;
  }
  double mean_us() const { return n_ ? static_cast<double>(sum_) / static_cast<double>(n_) / 1e3 : 0.0; }
  double p99_us() const {
    std::uint64_t need = (n_ * 99 + 99) / 100, seen = 0;
    for (std::size_t i = 0; i < hist_.size(); ++i) {
      seen += hist_[i];
      if (seen >= need && n_) return static_cast<double>((static_cast<Nanos>(i) + 1) * kBin) / 1e3;
    }
    return 0.0;
  }
  double max_jitter_us() const { return static_cast<double>(max_jitter_) / 1e3; }
  std::uint64_t cycles() const { return cycles_; }
  std::uint64_t misses() const { return misses_; }
  /// A missed cycle: its deadline and when its work finished (more than a period later).
  struct Miss {
    Nanos deadline = 0, finished = 0;
  };
  static constexpr std::size_t kMissLog = 8;
  /// The first min(misses(), kMissLog) misses.
  const std::array<Miss, kMissLog>& miss_log() const { return miss_log_; }

 private:
  static constexpr Nanos kBin = 10 * 1000;
  Nanos period_;
  Nanos last_wake_ = 0, sum_ = 0, max_jitter_ = 0;
  std::uint64_t n_ = 0, cycles_ = 0, misses_ = 0;
  std::array<std::uint32_t, 10000> hist_{};
  std::array<Miss, kMissLog> miss_log_{};
};

/// Durations of a piece of work (a scan's processing on the RT thread) without
/// allocation: p99 from a fixed histogram (10 µs bins up to 20 ms) and the maximum.
class WorkStats {
 public:
  void record(Nanos d) {
    const auto bin = static_cast<std::size_t>(std::max<Nanos>(0, d) / kBin);
    ++hist_[bin < hist_.size() ? bin : hist_.size() - 1];
    if (d > max_) max_ = d;
    ++n_;
  }
  double p99_us() const {
    std::uint64_t need = (n_ * 99 + 99) / 100, seen = 0;
    for (std::size_t i = 0; i < hist_.size(); ++i) {
      seen += hist_[i];
      if (seen >= need && n_) return static_cast<double>((static_cast<Nanos>(i) + 1) * kBin) / 1e3;
    }
    return 0.0;
  }
  double max_us() const { return static_cast<double>(max_) / 1e3; }

 private:
  static constexpr Nanos kBin = 10 * 1000;
  Nanos max_ = 0;
  std::uint64_t n_ = 0;
  std::array<std::uint32_t, 2000> hist_{};
};

}  // namespace cairn::firmware

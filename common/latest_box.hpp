// An RT-safe "latest value" box (triple buffer): one writer publishes whole
// values, one reader takes the newest one. Neither ever waits for the other,
// neither allocates, and the reader never sees a torn value.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>

namespace cairn {

template <typename T>
class LatestBox {
 public:
  LatestBox() = default;
  explicit LatestBox(const T& initial) { slots_.fill(initial); }

  /// Writer side: publishes a new value.
  void write(const T& v) {
    slots_[back_] = v;
    const std::uint8_t prev = middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel);
    back_ = prev & kIndexMask;
    writes_.fetch_add(1, std::memory_order_relaxed);
  }

  /// Reader side: copies the newest value into *out. Returns true if it is new
  /// since the last read (false: *out holds the previous value again).
  bool read(T* out) {
    bool fresh = false;
    if (middle_.load(std::memory_order_acquire) & kFresh) {
      const std::uint8_t prev = middle_.exchange(front_, std::memory_order_acq_rel);
      front_ = prev & kIndexMask;
      fresh = true;
    }
    *out = slots_[front_];
    return fresh;
  }

  /// Total number of writes (any thread).
  std::uint64_t writes() const { return writes_.load(std::memory_order_relaxed); }

 private:
  static constexpr std::uint8_t kFresh = 0x4;
  static constexpr std::uint8_t kIndexMask = 0x3;
  std::array<T, 3> slots_{};
  std::uint8_t back_ = 0;                // writer-owned
  std::atomic<std::uint8_t> middle_{1};  // shared: index | fresh bit
  std::uint8_t front_ = 2;               // reader-owned
  std::atomic<std::uint64_t> writes_{0};
};

}  // namespace cairn

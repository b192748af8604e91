// Lock-free single-producer / single-consumer queue with a capacity fixed at
// start-up. push and pop are wait-free and never allocate. A full queue refuses
// the element and counts the overflow (readable from any thread).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>

namespace cairn {

inline constexpr std::size_t kCacheLine = 64;

template <typename T>
class SpscQueue {
 public:
  /// Holds up to `capacity` elements.
  explicit SpscQueue(std::size_t capacity) : slots_(capacity + 1), data_(std::make_unique<T[]>(capacity + 1)) {}

  SpscQueue(const SpscQueue&) = delete;
  SpscQueue& operator=(const SpscQueue&) = delete;

  /// Producer side. Returns false (and counts) when full.
  [[nodiscard]] bool push(const T& v) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    const std::size_t next = tail + 1 == slots_ ? 0 : tail + 1;
    if (next == head_cache_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (next == head_cache_) {
        overflows_.fetch_add(1, std::memory_order_relaxed);
        return false;
      }
    }
    data_[tail] = v;
    tail_.store(next, std::memory_order_release);
    return true;
  }

  /// Consumer side. Returns false when empty.
  [[nodiscard]] bool pop(T* out) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_cache_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head == tail_cache_) return false;
    }
    *out = data_[head];
    head_.store(head + 1 == slots_ ? 0 : head + 1, std::memory_order_release);
    return true;
  }

  /// Consumer side: the oldest element without removing it, or nullptr.
  const T* front() {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_.load(std::memory_order_acquire)) return nullptr;
    return &data_[head];
  }

  /// Approximate when called concurrently.
  std::size_t size() const {
    const std::size_t h = head_.load(std::memory_order_acquire), t = tail_.load(std::memory_order_acquire);
    return t >= h ? t - h : slots_ - h + t;
  }
  std::size_t capacity() const { return slots_ - 1; }
  std::uint64_t overflows() const { return overflows_.load(std::memory_order_relaxed); }

 private:
  const std::size_t slots_;
  std::unique_ptr<T[]> data_;
  alignas(kCacheLine) std::atomic<std::size_t> head_{0};
  std::size_t tail_cache_ = 0;  // consumer's copy of tail_
  alignas(kCacheLine) std::atomic<std::size_t> tail_{0};
  std::size_t head_cache_ = 0;  // producer's copy of head_
  alignas(kCacheLine) std::atomic<std::uint64_t> overflows_{0};
};

}  // namespace cairn

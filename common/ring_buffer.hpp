// A single-threaded ring buffer of fixed capacity (set at start-up). When full,
// push either refuses (counted) or overwrites the oldest element (counted),
// as chosen at construction.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

namespace cairn {

enum class WhenFull { kReject, kOverwriteOldest };

template <typename T>
class RingBuffer {
 public:
  explicit RingBuffer(std::size_t capacity, WhenFull policy = WhenFull::kReject)
      : data_(std::make_unique<T[]>(capacity)), capacity_(capacity), policy_(policy) {}

  /// Returns false if the element was rejected; an overwrite returns true but counts a drop.
  bool push(const T& v) {
    if (capacity_ == 0) {
      ++overflows_;
      return false;
    }
    if (size_ == capacity_) {
      ++overflows_;
      if (policy_ == WhenFull::kReject) return false;
      head_ = (head_ + 1) % capacity_;
      --size_;
    }
    data_[(head_ + size_) % capacity_] = v;
    ++size_;
    return true;
  }
  bool pop(T* out) {
    if (size_ == 0) return false;
    *out = data_[head_];
    head_ = (head_ + 1) % capacity_;
    --size_;
    return true;
  }
  /// i-th element from the oldest (0) to the newest (size()-1).
  T& operator[](std::size_t i) { return data_[(head_ + i) % capacity_]; }
  const T& operator[](std::size_t i) const { return data_[(head_ + i) % capacity_]; }
  T& newest() { return (*this)[size_ - 1]; }
  T& oldest() { return (*this)[0]; }
  void clear() { head_ = size_ = 0; }

  std::size_t size() const { return size_; }
  std::size_t capacity() const { return capacity_; }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == capacity_; }
  std::uint64_t overflows() const { return overflows_; }

 private:
  std::unique_ptr<T[]> data_;
  std::size_t capacity_;
  WhenFull policy_;
  std::size_t head_ = 0;
  std::size_t size_ = 0;
  std::uint64_t overflows_ = 0;
};

}  // namespace cairn

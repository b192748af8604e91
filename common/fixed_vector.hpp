// A vector whose capacity is fixed when it is made (at start-up, from
// configuration). push_back never allocates: past capacity it refuses, counts
// the overflow, and reports it to the caller.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>

namespace cairn {

template <typename T>
class FixedVector {
 public:
  FixedVector() = default;
  explicit FixedVector(std::size_t capacity) : data_(std::make_unique<T[]>(capacity)), capacity_(capacity) {}

  FixedVector(FixedVector&&) noexcept = default;
  FixedVector& operator=(FixedVector&&) noexcept = default;
  FixedVector(const FixedVector&) = delete;
  FixedVector& operator=(const FixedVector&) = delete;

  /// Appends; returns false (and counts an overflow) when full.
  [[nodiscard]] bool push_back(const T& value) {
    if (size_ == capacity_) {
      ++overflows_;
      return false;
    }
    data_[size_++] = value;
    return true;
  }
  /// Default-constructs a slot in place and returns it, or nullptr (counted) when full.
  [[nodiscard]] T* emplace_slot() {
    if (size_ == capacity_) {
      ++overflows_;
      return nullptr;
    }
    data_[size_] = T{};
    return &data_[size_++];
  }
  void pop_back() {
    if (size_ > 0) --size_;
  }
  void clear() { size_ = 0; }
  /// Shrinks to n (n <= size); never grows.
  void truncate(std::size_t n) {
    if (n < size_) size_ = n;
  }

  std::size_t size() const { return size_; }
  std::size_t capacity() const { return capacity_; }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == capacity_; }
  std::uint64_t overflows() const { return overflows_; }

  T& operator[](std::size_t i) { return data_[i]; }
  const T& operator[](std::size_t i) const { return data_[i]; }
  T& at(std::size_t i) {
    if (i >= size_) throw std::out_of_range("FixedVector::at");
    return data_[i];
  }
  T* begin() { return data_.get(); }
  T* end() { return data_.get() + size_; }
  const T* begin() const { return data_.get(); }
  const T* end() const { return data_.get() + size_; }
  T* data() { return data_.get(); }
  const T* data() const { return data_.get(); }
  std::span<T> span() { return {data_.get(), size_}; }
  std::span<const T> span() const { return {data_.get(), size_}; }

 private:
  std::unique_ptr<T[]> data_;
  std::size_t capacity_ = 0;
  std::size_t size_ = 0;
  std::uint64_t overflows_ = 0;
};

}  // namespace cairn

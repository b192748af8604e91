// An arena that hands out memory during start-up only. After seal(), every
// allocation fails (returns nullptr) and is counted: the real-time path can
// prove it never asks for memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>

namespace cairn {

class Arena {
 public:
  explicit Arena(std::size_t bytes) : buffer_(std::make_unique<std::byte[]>(bytes)), capacity_(bytes) {}
  Arena(const Arena&) = delete;
  Arena& operator=(const Arena&) = delete;
  ~Arena() = default;

  /// Raw memory; nullptr (counted) when sealed or exhausted.
  void* allocate(std::size_t size, std::size_t align = alignof(std::max_align_t)) {
    if (sealed_) {
      ++refused_;
      return nullptr;
    }
    const std::size_t start = (used_ + align - 1) / align * align;
    if (start + size > capacity_ || start + size < start) {
      ++refused_;
      return nullptr;
    }
    used_ = start + size;
    return buffer_.get() + start;
  }

  /// An array of n default-constructed T (trivially destructible only: the arena never runs destructors).
  template <typename T>
  T* make_array(std::size_t n) {
    static_assert(std::is_trivially_destructible_v<T>, "arena objects are never destroyed");
    void* p = allocate(sizeof(T) * n, alignof(T));
    if (!p) return nullptr;
    T* arr = static_cast<T*>(p);
    for (std::size_t i = 0; i < n; ++i) new (arr + i) T();
    return arr;
  }

  template <typename T, typename... Args>
  T* make(Args&&... args) {
    static_assert(std::is_trivially_destructible_v<T>, "arena objects are never destroyed");
    void* p = allocate(sizeof(T), alignof(T));
    return p ? new (p) T(std::forward<Args>(args)...) : nullptr;
  }

  /// Ends start-up: no further allocation succeeds.
  void seal() { sealed_ = true; }
  bool sealed() const { return sealed_; }
  std::size_t used() const { return used_; }
  std::size_t capacity() const { return capacity_; }
  std::uint64_t refused() const { return refused_; }

 private:
  std::unique_ptr<std::byte[]> buffer_;
  std::size_t capacity_;
  std::size_t used_ = 0;
  bool sealed_ = false;
  std::uint64_t refused_ = 0;
};

}  // namespace cairn

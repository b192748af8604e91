// A logger that is safe to call from the real-time path. A call copies its
// arguments into a fixed-size record and pushes it into a lock-free bounded
// ring (many producers, one consumer); a non-RT thread drains, formats and
// writes the records. Nothing on the calling side allocates, locks or blocks;
// a full ring drops the record and counts it.
//
// Format strings use "{}" placeholders, or "{:SPEC}" with a printf spec
// ("{:.3f}", "{:x}", "{:5d}"). The format string must be a literal (it is
// stored by pointer); string arguments are copied (truncated to fit).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <type_traits>

#include "common/clock.hpp"

namespace cairn {

enum class LogLevel : std::uint8_t { kDebug, kInfo, kWarn, kError };
const char* log_level_name(LogLevel level);

struct LogArg {
  enum class Kind : std::uint8_t { kNone, kInt, kUint, kDouble, kText, kBool };
  Kind kind = Kind::kNone;
  union {
    std::int64_t i;
    std::uint64_t u;
    double d;
    std::uint16_t text_offset;  // into LogRecord::text
  };
  LogArg() : i(0) {}
};

struct LogRecord {
  static constexpr std::size_t kMaxArgs = 8;
  static constexpr std::size_t kTextBytes = 192;
  Nanos time = 0;
  LogLevel level = LogLevel::kInfo;
  std::uint8_t nargs = 0;
  const char* component = "";
  const char* format = "";
  LogArg args[kMaxArgs];
  char text[kTextBytes] = {};
  std::uint16_t text_used = 0;
};

/// Formats a record's message (without time/level prefix). Non-RT.
std::string format_log_message(const LogRecord& r);

class Logger {
 public:
  using Sink = std::function<void(const LogRecord&, const std::string& line)>;

  explicit Logger(std::size_t capacity = 4096);
  ~Logger();
  Logger(const Logger&) = delete;
  Logger& operator=(const Logger&) = delete;

  /// Starts the drain thread (non-RT). Without it, records wait in the ring until drain() is called.
  void start();
  /// Drains what is left and stops the thread.
  void stop();
  /// Formats and writes every queued record (called by the drain thread, or by hand in tests).
  std::size_t drain();
  /// Replaces the output (default: stderr). Set before start().
  void set_sink(Sink sink);
  void set_min_level(LogLevel level) { min_level_.store(level, std::memory_order_relaxed); }
  void set_clock(const Clock* clock) { clock_ = clock; }

  template <typename... Args>
  void log(LogLevel level, const char* component, const char* format, const Args&... args) {
    static_assert(sizeof...(Args) <= LogRecord::kMaxArgs, "too many log arguments");
    if (level < min_level_.load(std::memory_order_relaxed)) return;
    LogRecord* r = claim();
    if (!r) return;
    r->time = clock_->now();
    r->level = level;
    r->component = component;
    r->format = format;
    r->nargs = 0;
    r->text_used = 0;
    (put(r, args), ...);
    commit(r);
  }

  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }
  std::uint64_t written() const { return written_.load(std::memory_order_relaxed); }
  std::size_t capacity() const { return capacity_; }

 private:
  struct Cell {
    std::atomic<std::size_t> sequence;
    LogRecord record;
  };

  LogRecord* claim();
  void commit(LogRecord* r);
  static void put_text(LogRecord* r, std::string_view s);

  template <typename T>
  static void put(LogRecord* r, const T& v) {
    LogArg& a = r->args[r->nargs++];
    using D = std::decay_t<T>;
    if constexpr (std::is_same_v<D, bool>) {
      a.kind = LogArg::Kind::kBool;
      a.u = v ? 1 : 0;
    } else if constexpr (std::is_floating_point_v<D>) {
      a.kind = LogArg::Kind::kDouble;
      a.d = static_cast<double>(v);
    } else if constexpr (std::is_enum_v<D>) {
      a.kind = LogArg::Kind::kInt;
      a.i = static_cast<std::int64_t>(v);
    } else if constexpr (std::is_integral_v<D> && std::is_signed_v<D>) {
      a.kind = LogArg::Kind::kInt;
      a.i = v;
    } else if constexpr (std::is_integral_v<D>) {
      a.kind = LogArg::Kind::kUint;
      a.u = v;
    } else if constexpr (std::is_convertible_v<const T&, std::string_view>) {
      a.kind = LogArg::Kind::kText;
      a.text_offset = r->text_used;
      put_text(r, std::string_view(v));
    } else {
      static_assert(sizeof(T) == 0, "unsupported log argument type");
    }
  }

  const std::size_t capacity_;
  std::unique_ptr<Cell[]> cells_;
  alignas(64) std::atomic<std::size_t> enqueue_pos_{0};
  alignas(64) std::atomic<std::size_t> dequeue_pos_{0};
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<std::uint64_t> written_{0};
  std::atomic<LogLevel> min_level_{LogLevel::kInfo};
  std::atomic<bool> running_{false};
  std::thread thread_;
  std::mutex sink_mutex_;  // drain side only; producers never touch it
  std::uint64_t dropped_reported_ = 0;  // drain side
  Sink sink_;
  const Clock* clock_ = &MonotonicClock::instance();
};

/// The process-wide logger.
Logger& logger();

#define CAIRN_LOG_DEBUG(component, ...) ::cairn::logger().log(::cairn::LogLevel::kDebug, component, __VA_ARGS__)
#define CAIRN_LOG_INFO(component, ...) ::cairn::logger().log(::cairn::LogLevel::kInfo, component, __VA_ARGS__)
#define CAIRN_LOG_WARN(component, ...) ::cairn::logger().log(::cairn::LogLevel::kWarn, component, __VA_ARGS__)
#define CAIRN_LOG_ERROR(component, ...) ::cairn::logger().log(::cairn::LogLevel::kError, component, __VA_ARGS__)

}  // namespace cairn

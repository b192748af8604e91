#include "common/log.hpp"

#include <cstdint>

#include <chrono>
#include <cinttypes>

namespace cairn {

const char* log_level_name(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug: return "debug";
    case LogLevel::kInfo: return "info";
    case LogLevel::kWarn: return "warn";
    case LogLevel::kError: return "error";
  }
  return "?";
}

namespace {

// The printf spec comes from the record's format string, built here at drain time.
#pragma GCC diagnostic ignored "-Wformat-nonliteral"

// Formats one argument with an optional printf spec (without '%'), e.g. ".3f".
void append_arg(std::string* out, const LogRecord& r, const LogArg& a, std::string_view spec) {
  char buf[128];
  std::string f = "%";
  const bool has_spec = !spec.empty();
  const char conv = has_spec ? spec.back() : '\0';
  if (has_spec) f.append(spec.substr(0, spec.size() - 1));
  int n = 0;
  switch (a.kind) {
    case LogArg::Kind::kInt:
      if (has_spec && (conv == 'f' || conv == 'g' || conv == 'e')) {
        n = std::snprintf(buf, sizeof buf, (f + conv).c_str(), static_cast<double>(a.i));
      } else if (has_spec && (conv == 'x' || conv == 'X' || conv == 'o')) {
        n = std::snprintf(buf, sizeof buf, (f + "ll" + conv).c_str(), static_cast<unsigned long long>(a.i));
      } else {
        n = std::snprintf(buf, sizeof buf, (f + "lld").c_str(), static_cast<long long>(a.i));
      }
      break;
    case LogArg::Kind::kUint:
    case LogArg::Kind::kBool:
      if (a.kind == LogArg::Kind::kBool) {
        n = std::snprintf(buf, sizeof buf, "%s", a.u ? "true" : "false");
      } else if (has_spec && (conv == 'f' || conv == 'g' || conv == 'e')) {
        n = std::snprintf(buf, sizeof buf, (f + conv).c_str(), static_cast<double>(a.u));
      } else if (has_spec && (conv == 'x' || conv == 'X' || conv == 'o')) {
        n = std::snprintf(buf, sizeof buf, (f + "ll" + conv).c_str(), static_cast<unsigned long long>(a.u));
      } else {
        n = std::snprintf(buf, sizeof buf, (f + "llu").c_str(), static_cast<unsigned long long>(a.u));
      }
      break;
    case LogArg::Kind::kDouble:
      if (has_spec && (conv == 'f' || conv == 'g' || conv == 'e')) {
        n = std::snprintf(buf, sizeof buf, (f + conv).c_str(), a.d);
      } else {
        n = std::snprintf(buf, sizeof buf, "%g", a.d);
      }
      break;
    case LogArg::Kind::kText:
      out->append(r.text + a.text_offset);
      return;
    case LogArg::Kind::kNone:
      return;
  }
  if (n > 0) out->append(buf, std::min<std::size_t>(static_cast<std::size_t>(n), sizeof buf - 1));
}

}  // namespace

std::string format_log_message(const LogRecord& r) {
  std::string out;
  std::size_t next = 0;
  for (const char* p = r.format; *p; ++p) {
    if (p[0] == '{' && p[1] == '{') {
      out.push_back('{');
      ++p;
      continue;
    }
    if (p[0] == '}' && p[1] == '}') {
      out.push_back('}');
      ++p;
      continue;
    }
    if (*p == '{') {
      const char* close = std::strchr(p, '}');
      if (!close) {
        out.append(p);
        break;
      }
      std::string_view inner(p + 1, static_cast<std::size_t>(close - p - 1));
      std::string_view spec = (!inner.empty() && inner.front() == ':') ? inner.substr(1) : std::string_view{};
      if (next < r.nargs) {
        append_arg(&out, r, r.args[next++], spec);
      } else {
        out.append("{?}");
      }
      p = close;
      continue;
    }
    out.push_back(*p);
  }
  return out;
}

Logger::Logger(std::size_t capacity) : capacity_(capacity < 2 ? 2 : capacity), cells_(std::make_unique<Cell[]>(capacity_)) {
  for (std::size_t i = 0; i < capacity_; ++i) cells_[i].sequence.store(i, std::memory_order_relaxed);
  sink_ = [](const LogRecord&, const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
}

Logger::~Logger() { stop(); }

// Bounded MPMC ring (Vyukov): each cell's sequence tells whose turn it is.
LogRecord* Logger::claim() {
  std::size_t pos = enqueue_pos_.load(std::memory_order_relaxed);
  for (;;) {
    Cell& cell = cells_[pos % capacity_];
    const std::size_t seq = cell.sequence.load(std::memory_order_acquire);
    const auto diff = static_cast<std::intptr_t>(seq) - static_cast<std::intptr_t>(pos);
    if (diff == 0) {
      if (enqueue_pos_.compare_exchange_weak(pos, pos + 1, std::memory_order_relaxed)) return &cell.record;
    } else if (diff < 0) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return nullptr;
    } else {
      pos = enqueue_pos_.load(std::memory_order_relaxed);
    }
  }
}

void Logger::commit(LogRecord* r) {
  // The record is a member of one of cells_: find that cell by its index (no pointer cast,
  // which 32-bit Arm flags as raising the required alignment).
  const auto offset = reinterpret_cast<std::uintptr_t>(r) - reinterpret_cast<std::uintptr_t>(&cells_[0].record);
  Cell* cell = &cells_[offset / sizeof(Cell)];
  // While claimed, the cell's sequence still equals the claiming position; pos + 1 hands it to the consumer.
  const std::size_t pos = cell->sequence.load(std::memory_order_relaxed);
  cell->sequence.store(pos + 1, std::memory_order_release);
}

void Logger::put_text(LogRecord* r, std::string_view s) {
  // text[kTextBytes - 1] is never written and stays '\0': a text argument that finds no
  // room left points there and reads as "" (it used to point past the buffer).
  const std::size_t end = LogRecord::kTextBytes - 1;
  if (r->text_used >= end) {
    r->text_used = static_cast<std::uint16_t>(end);
    return;
  }
  const std::size_t room = end - r->text_used;
  const std::size_t n = std::min(s.size(), room - 1);
  std::memcpy(r->text + r->text_used, s.data(), n);
  r->text[r->text_used + n] = '\0';
  r->text_used = static_cast<std::uint16_t>(r->text_used + n + 1);
}

std::size_t Logger::drain() {
  std::lock_guard lock(sink_mutex_);
  std::size_t count = 0;
  for (;;) {
    std::size_t pos = dequeue_pos_.load(std::memory_order_relaxed);
    Cell& cell = cells_[pos % capacity_];
    const std::size_t seq = cell.sequence.load(std::memory_order_acquire);
    if (static_cast<std::intptr_t>(seq) - static_cast<std::intptr_t>(pos + 1) < 0) break;  // empty
    dequeue_pos_.store(pos + 1, std::memory_order_relaxed);
    const LogRecord& r = cell.record;
    char prefix[96];
    std::snprintf(prefix, sizeof prefix, "[%12.6f] %-5s %s: ", nanos_to_seconds(r.time), log_level_name(r.level),
                  r.component);
    std::string line = prefix + format_log_message(r);
    sink_(r, line);
    cell.sequence.store(pos + capacity_, std::memory_order_release);
    ++count;
  }
  const std::uint64_t dropped_now = dropped_.load(std::memory_order_relaxed);
  const std::uint64_t lost = dropped_now - dropped_reported_;
  dropped_reported_ = dropped_now;
  if (lost > 0) {
    std::string line = "log: " + std::to_string(lost) + " record(s) dropped because the log ring was full";
    LogRecord r;
    r.level = LogLevel::kWarn;
    r.component = "log";
    sink_(r, line);
  }
  written_.fetch_add(count, std::memory_order_relaxed);
  return count;
}

void Logger::set_sink(Sink sink) {
  std::lock_guard lock(sink_mutex_);
  sink_ = std::move(sink);
}

void Logger::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] {
    while (running_.load(std::memory_order_acquire)) {
      if (drain() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    drain();
  });
}

void Logger::stop() {
  if (!running_.exchange(false)) {
    drain();
    return;
  }
  if (thread_.joinable()) thread_.join();
}

Logger& logger() {
  static Logger instance;
  return instance;
}

}  // namespace cairn

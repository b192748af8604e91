// The LMS2xx driver: a state machine over a byte stream and a clock passed in.
//
//   searching   probe each baud rate (the configured one first) with "stop streaming"
//               and a status request until a valid telegram answers
//   configuring stop streaming -> switch to the target baud (verified) -> type ->
//               installation mode -> configuration (mm, 32 m range, reflector bit) ->
//               variant (angle, resolution) -> leave installation -> stream all values
//   streaming   decode B0 telegrams into scans; silence, a power-on telegram or an I/O
//               error sends it back to searching (with the reason), reopening the link
//               with back-off if it broke
//
// Every timeout is named and configurable. step() does one bounded read and never blocks
// longer than `io_slice`; after construction nothing allocates.
#pragma once

#include <array>
#include <cstdint>

#include "common/clock.hpp"
#include "drivers/serial/byte_stream.hpp"
#include "drivers/sick/lms_codec.hpp"

namespace cairn::lms {

struct LmsDriverConfig {
  std::uint32_t target_baud = 500000;  // 38400 where the adapter cannot do 500 kBd (RS-232)
  std::uint16_t angle_deg = 180;        // 100 or 180
  std::uint16_t resolution_centideg = 50;  // 100 (1°), 50 (0.5°), 25 (0.25°, 100° only)
  std::array<char, 9> password = {'S', 'I', 'C', 'K', '_', 'L', 'M', 'S', 0};
  Nanos probe_timeout = 250 * kNanosPerMilli;     // per baud rate while searching
  Nanos reply_timeout = 500 * kNanosPerMilli;     // ordinary request -> reply
  Nanos mode_timeout = 3 * kNanosPerSecond;       // mode changes (installation mode is slow)
  Nanos stream_timeout = 500 * kNanosPerMilli;    // no scan for this long (plus two telegram line times): reconnect
  Nanos baud_settle = 30 * kNanosPerMilli;        // after switching the host's rate
  Nanos reopen_backoff = 500 * kNanosPerMilli;    // between attempts to reopen a broken link
  int retries = 3;                                // per configuration step
  Nanos io_slice = 5 * kNanosPerMilli;            // longest a step() waits for bytes
  Nanos scan_latency = -1;                        // first beam before first byte; -1: one sweep
};

enum class DriverState : std::uint8_t { kSearching, kConfiguring, kStreaming, kError };
const char* state_name(DriverState s);

struct LmsCounters {
  std::uint64_t scans = 0, crc_errors = 0, resyncs = 0, timeouts = 0, reconnects = 0, io_errors = 0;
  std::uint64_t naks = 0, power_on_telegrams = 0, bad_scans = 0;
};

/// One scan, fixed size. Ranges in mm, 0 = no return; flags: the reflector bit(s).
struct LmsScan {
  std::uint32_t seq = 0;
  Nanos first_byte_time = 0;  // baud-aware estimate of when the telegram's first byte arrived
  Nanos stamp = 0;            // first beam measured (first_byte_time - scan latency)
  double angle_min = 0;       // rad (sensor frame, 0 = ahead)
  double angle_increment = 0;
  double beam_period_s = 0;
  std::uint16_t count = 0;
  std::array<std::uint16_t, kMaxBeams> range_mm{};
  std::array<std::uint8_t, kMaxBeams> flags{};
  /// Beam i's angle (rad, sensor frame).
  double angle(std::size_t i) const { return angle_min + angle_increment * static_cast<double>(i); }
};

class ScanSink {
 public:
  virtual ~ScanSink() = default;
  virtual void on_scan(const LmsScan& scan) = 0;
};

class LmsDriver {
 public:
  LmsDriver(serial::ByteStream* stream, Clock* clock, const LmsDriverConfig& cfg, ScanSink* sink);

  /// One bounded step of the state machine (the I/O thread calls it in a loop).
  void step();

  DriverState state() const { return state_; }
  /// Why the driver is in its state ("streaming at 500000 baud", "no reply to 0x3B at 38400 baud", ...).
  const char* reason() const { return reason_.data(); }
  const LmsCounters& counters() const;
  std::uint32_t baud() const { return stream_->baud(); }
  const char* device_type() const { return type_.data(); }

 private:
  enum class Step : std::uint8_t {
    kStop, kBaud, kVerify, kType, kInstall, kConfig, kVariant, kLeave, kStart, kDone
  };
  void enter(DriverState s, const char* fmt, ...) __attribute__((format(printf, 3, 4)));
  void send(const Frame& f, std::uint8_t expect, Nanos timeout);
  void start_search();
  void probe_next();
  void begin_step(Step s);
  void on_telegram(const Telegram& t, Nanos read_time, std::size_t bytes_after);
  void on_reply(const Telegram& t);
  void on_timeout(Nanos now);
  void handle_io_failure(const serial::IoResult& r, Nanos now);
  void emit_scan(const Telegram& t, Nanos end_time);

  serial::ByteStream* stream_;
  Clock* clock_;
  LmsDriverConfig cfg_;
  ScanSink* sink_;
  Parser parser_{kReplyAddress};
  DriverState state_ = DriverState::kSearching;
  Step step_ = Step::kStop;
  std::array<char, 128> reason_{};
  std::array<char, 96> link_name_{};  // stream_->describe(), copied at construction: no std::string on the I/O thread
  std::array<char, 24> type_{};
  std::array<std::uint8_t, 1024> rx_{};
  // Waiting for a reply.
  std::uint8_t expect_ = 0;
  Nanos deadline_ = 0;
  int attempts_ = 0;
  Frame last_request_;
  Nanos last_timeout_value_ = 0;
  // Searching.
  std::size_t probe_index_ = 0;
  std::array<std::uint32_t, 4> probe_order_{};
  // Streaming.
  Nanos last_scan_ = 0;
  Nanos reopen_at_ = 0;
  Nanos settle_until_ = 0;
  std::uint32_t seq_ = 0;
  ScanValues values_;
  LmsScan scan_;
  mutable LmsCounters counters_;
  std::uint8_t measuring_mode_ = 0x05;
};

}  // namespace cairn::lms

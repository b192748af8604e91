// An emulated SICK LMS2xx: the device's behaviour on the wire, byte for byte, using the
// same codec as the driver. Pure model: the caller passes time in, feeds the bytes the
// host sent, and drains the bytes the device transmits (LmsServer paces them at the
// device's baud over a pty or TCP).
//
// Behaviour: power-on telegram (0x90) at 9600 after the boot time; every request is
// answered with ACK (0x06) or, on a bad CRC, NAK (0x15); then the reply (request + 0x80);
// 0x92 for unknown commands; a baud change is answered at the old rate (status 0x10) and
// takes effect once that reply is on the wire; installation mode needs the password;
// configuration writes need installation mode; in mode 0x24 one B0 telegram per completed
// scan (75 Hz mirror; 1 / 2 / 4 rotations per scan at 1° / 0.5° / 0.25°), dropped when the
// line is still busy with the previous one.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <random>
#include <string>

#include "common/clock.hpp"
#include "common/se2.hpp"
#include "drivers/sick/lms_codec.hpp"
#include "hil/world/world.hpp"

namespace cairn::hil {

struct LmsDeviceConfig {
  double boot_time_s = 0.3;        // power-on to the 0x90 telegram (a real LMS takes ~30 s)
  std::string type = "LMS291;S05";  // 0x3A reply text
  double range_noise_m = 0.005;    // σ of Gaussian range noise
  double max_range_m = 30.0;
  std::uint64_t seed = 1;
  std::string password = "SICK_LMS";
  // The rate the device wakes at: 9600 from the factory; a device whose baud rate was set
  // permanently (as behind a serial device server at a fixed rate) wakes at that rate.
  std::uint32_t power_on_baud = 9600;
  // Interlaced output, as in the partial-scan modes (0x2A): successive telegrams carry
  // partial-scan index 0, 1, 2, 3 in the count word (bits 11-12), each sweep turned by
  // index x 0.25 deg (protocols.md 1.6). Off: every telegram is index 0, as in mode 0x24.
  bool interlaced = false;
};

/// What the device knows about the scan it sends (for tests: ground truth per scan).
struct SentScan {
  std::uint32_t index = 0;
  Nanos sweep_start = 0;        // first beam measured
  Nanos tx_start = -1;          // when its first byte went on the wire (set by the server)
  std::uint64_t first_byte = 0; // index of its STX in the device's output byte stream
  // When the write() holding its last byte began (the server's clock): a host cannot have
  // the telegram earlier. Later than tx_start + bytes on the line when the server ran late.
  Nanos last_byte_written = -1;
  std::size_t bytes = 0;
  Pose2 sensor_pose;
  // Identity of its content as a host decodes it (ranges in mm, 0 = no echo, and flags):
  // with range noise every scan differs, so tests match received scans to sent ones by
  // this, not by time.
  std::uint64_t fingerprint = 0;
};

/// FNV-1a over a scan's decoded ranges (mm, 0 = no echo) and flags: what SentScan holds,
/// and what a test computes from a driver's LmsScan.
inline std::uint64_t scan_fingerprint(std::size_t count, const std::uint16_t* range_mm, const std::uint8_t* flags) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](std::uint8_t b) { h = (h ^ b) * 1099511628211ull; };
  for (std::size_t i = 0; i < count; ++i) {
    mix(static_cast<std::uint8_t>(range_mm[i]));
    mix(static_cast<std::uint8_t>(range_mm[i] >> 8));
    mix(flags[i]);
  }
  return h;
}

class LmsDevice {
 public:
  using PoseSource = std::function<Pose2(Nanos)>;  // the sensor's world pose at a time
  LmsDevice(LmsDeviceConfig cfg, const World* world, PoseSource pose);

  void power_on(Nanos now);
  /// Bytes the host sent (as received at the device's baud).
  void receive(std::span<const std::uint8_t> bytes, Nanos now);
  /// Advances time: queues the power-on telegram and scans when due.
  void poll(Nanos now, bool line_idle);
  /// The server reports that everything queued so far has left (baud switches happen now).
  void on_tx_drained(Nanos now);

  const std::deque<std::uint8_t>& tx() const { return tx_; }
  /// Takes the next byte off the output queue (the server transmits it).
  std::uint8_t pop_tx() {
    ++popped_;
    const std::uint8_t b = tx_.front();
    tx_.pop_front();
    return b;
  }
  /// Bytes taken off the output queue (or discarded by a power cycle) so far.
  std::uint64_t popped() const { return popped_; }
  std::uint32_t baud() const { return baud_; }
  bool streaming() const { return streaming_; }

  // ---- fault injection (protocols.md §1; the driver must survive each)
  void inject_garbage(std::size_t n);       // random bytes on the line now
  void corrupt_next_telegram_crc();         // next telegram goes out with a flipped CRC byte
  void drop_from_next_telegram(std::size_t n);  // next telegram loses n bytes in the middle
  void force_baud(std::uint32_t baud);      // device jumps to another rate (host sees garbage)

  // ---- observability
  struct Counters {
    std::uint64_t requests = 0, naks_sent = 0, unknown_commands = 0, scans_sent = 0, scans_dropped_busy = 0;
    std::uint64_t baud_changes = 0, power_ons = 0;
  };
  const Counters& counters() const { return counters_; }
  /// Scans sent so far (the last ~1000), for tests.
  std::deque<SentScan>& sent_scans() { return sent_; }
  std::uint16_t angle() const { return angle_; }
  std::uint16_t resolution() const { return res_; }
  std::uint8_t units() const { return config_.bytes[6]; }

 private:
  void handle(const lms::Telegram& t, Nanos now);
  void reply(std::uint8_t code, std::span<const std::uint8_t> data, std::uint8_t status = 0x00);
  void queue(const lms::Frame& f);
  void queue_scan(Nanos now);
  std::uint16_t encode_range(double range_m, bool hit, bool reflective) const;

  LmsDeviceConfig cfg_;
  const World* world_;
  PoseSource pose_;
  std::mt19937_64 rng_;
  lms::Parser parser_{lms::kHostAddress};
  std::deque<std::uint8_t> tx_;
  std::uint64_t popped_ = 0;
  std::uint32_t baud_ = 9600;
  std::uint32_t pending_baud_ = 0;
  bool booted_ = false;
  Nanos boot_done_ = 0;
  bool installation_ = false;
  bool streaming_ = false;
  std::uint16_t angle_ = 180, res_ = 100;
  lms::ConfigBlock config_;   // units etc.
  Nanos next_scan_ = 0;
  std::uint32_t scan_index_ = 0;
  std::uint8_t partial_ = 0;  // the next partial-scan index (interlaced)
  bool corrupt_crc_ = false;
  std::size_t drop_bytes_ = 0;
  Counters counters_;
  std::deque<SentScan> sent_;
};

}  // namespace cairn::hil

// SICK LMS2xx serial telegram codec: framing, SICK's CRC-16, requests, responses and the
// measured-values telegram. Pure: bytes in, typed values out; no I/O, no clock, no heap.
// Facts and test vectors: ../shared/docs/protocols.md §1 (telegram = STX ADDR LEN(2,LE)
// CMD DATA.. [STATUS] CRC(2,LE); LEN counts CMD..last data byte; CRC over STX..last).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace cairn::lms {

inline constexpr std::uint8_t kStx = 0x02;
inline constexpr std::uint8_t kAck = 0x06;
inline constexpr std::uint8_t kNak = 0x15;
inline constexpr std::uint8_t kHostAddress = 0x00;   // requests go to the LMS at address 0
inline constexpr std::uint8_t kReplyAddress = 0x80;  // replies come from 0x80 | LMS address
inline constexpr std::size_t kMaxPayload = 812;      // CMD .. STATUS (sicktoolbox's bound)
inline constexpr std::size_t kMaxTelegram = kMaxPayload + 6;
inline constexpr std::size_t kMaxBeams = 721;

/// SICK's CRC-16 (poly 0x8005 in byte-pair form; NOT CRC-16/ARC): protocols.md §1.3.
std::uint16_t crc16(std::span<const std::uint8_t> bytes);

// ---- commands and codes
enum Command : std::uint8_t {
  kCmdReset = 0x10,
  kCmdMode = 0x20,
  kCmdRequestValues = 0x30,
  kCmdStatus = 0x31,
  kCmdErrors = 0x32,
  kCmdType = 0x3A,
  kCmdVariant = 0x3B,
  kCmdReadConfig = 0x74,
  kCmdWriteConfig = 0x77,
};
enum Reply : std::uint8_t {
  kReplyPowerOn = 0x90,
  kReplyReset = 0x91,
  kReplyNack = 0x92,  // unknown or invalid command
  kReplyMode = 0xA0,
  kReplyValues = 0xB0,
  kReplyStatus = 0xB1,
  kReplyErrors = 0xB2,
  kReplyType = 0xBA,
  kReplyVariant = 0xBB,
  kReplyConfig = 0xF4,
  kReplyWriteConfig = 0xF7,
};
enum Mode : std::uint8_t {
  kModeInstallation = 0x00,
  kModeStreamAll = 0x24,
  kModeOnRequest = 0x25,
  kBaud38400 = 0x40,
  kBaud19200 = 0x41,
  kBaud9600 = 0x42,
  kBaud500000 = 0x48,
};

/// The 0x20 mode byte that switches to `baud`, or nullopt for an unsupported rate.
std::optional<std::uint8_t> baud_code(std::uint32_t baud);
/// The baud rate for a 0x20 mode byte, or 0.
std::uint32_t baud_of_code(std::uint8_t code);
inline constexpr std::array<std::uint32_t, 4> kBauds = {9600, 19200, 38400, 500000};
/// One of the line rates an LMS2xx can switch to (kBauds).
constexpr bool valid_baud(std::uint32_t baud) {
  for (std::uint32_t b : kBauds) {
    if (b == baud) return true;
  }
  return false;
}
/// The scanning variants an LMS2xx offers (0x3B): a 100 deg field at 1, 0.5 or 0.25 deg,
/// a 180 deg field at 1 or 0.5 deg. One rule for the driver's config, the emulator and tools.
constexpr bool valid_variant(std::uint16_t angle_deg, std::uint16_t res_centideg) {
  return (angle_deg == 100 && (res_centideg == 100 || res_centideg == 50 || res_centideg == 25)) ||
         (angle_deg == 180 && (res_centideg == 100 || res_centideg == 50));
}

/// A telegram as bytes (fixed buffer).
struct Frame {
  std::array<std::uint8_t, kMaxTelegram> bytes{};
  std::size_t size = 0;
  std::span<const std::uint8_t> view() const { return {bytes.data(), size}; }
};

/// Builds STX ADDR LEN CMD DATA CRC. Returns false if the data is too long.
bool encode(std::uint8_t address, std::uint8_t command, std::span<const std::uint8_t> data, Frame* out);

// ---- requests (host -> LMS)
Frame request_mode(std::uint8_t mode);                                      // 0x20 <mode>
Frame request_installation_mode(std::string_view password = "SICK_LMS");    // 0x20 0x00 <8 bytes>
Frame request_status();                                                     // 0x31
Frame request_type();                                                       // 0x3A
Frame request_variant(std::uint16_t angle_deg, std::uint16_t res_centideg);  // 0x3B
Frame request_read_config();                                                // 0x74
/// 0x77 with the 32-byte configuration block (units, measuring mode; see ConfigBlock).
Frame request_write_config(std::span<const std::uint8_t, 32> block);
Frame request_reset();                                                      // 0x10
Frame request_values();                                                     // 0x30 0x01

/// The 32-byte configuration block (protocols.md §1.9), the fields Cairn uses.
struct ConfigBlock {
  std::array<std::uint8_t, 32> bytes{};
  std::uint8_t measuring_mode() const { return bytes[5]; }
  std::uint8_t units() const { return bytes[6]; }  // 0 cm, 1 mm, 2 dm
  static ConfigBlock millimetres();                  // Olin's mm block: k6 = 1, k9 = 2, k10 = 2
};

// ---- parsed telegrams
struct Telegram {
  std::uint8_t address = 0;
  std::uint8_t command = 0;                  // request command or reply code
  std::span<const std::uint8_t> data;        // bytes after CMD up to (not including) CRC; includes STATUS for replies
  std::uint16_t length = 0;                  // LEN field
};

/// Units of range values.
enum class Units : std::uint8_t { kCentimetres = 0, kMillimetres = 1, kDecimetres = 2 };

/// A decoded measured-values telegram (0xB0). Ranges in millimetres; flags are the bits
/// above the range field for the configured measuring mode (reflectivity / field flags).
struct ScanValues {
  std::uint16_t count = 0;
  std::uint8_t partial_index = 0;  // interlaced partial scan 0..3
  Units units = Units::kCentimetres;
  std::array<std::uint16_t, kMaxBeams> range_mm{};
  std::array<std::uint8_t, kMaxBeams> flags{};
  std::uint8_t status = 0;
  std::uint16_t saturated = 0;  // values that exceeded 65535 mm after unit conversion (clamped)
};

/// Range-field width (bits) for a measuring mode (protocols.md §1.6).
int range_bits(std::uint8_t measuring_mode);

/// Decodes a 0xB0 reply's data; false (and nothing else) on a malformed telegram.
bool decode_values(const Telegram& t, std::uint8_t measuring_mode, ScanValues* out);

struct VariantReply {
  bool accepted = false;
  std::uint16_t angle_deg = 0, res_centideg = 0;
};
bool decode_variant(const Telegram& t, VariantReply* out);

struct StatusReply {
  std::uint8_t operating_mode = 0, device_status = 0, measuring_mode = 0, units = 0;
  std::uint16_t scan_angle = 0, resolution = 0;
  std::array<char, 8> version{};
};
/// The 0xB1 status block (fields at sicktoolbox's offsets; needs >= 124 data bytes).
bool decode_status(const Telegram& t, StatusReply* out);

/// Builds the data of a 0xB1 status reply (for the emulator): 152 bytes + status.
void encode_status_data(const StatusReply& s, std::array<std::uint8_t, 153>* data);

// ---- stream parser
struct ParserCounters {
  std::uint64_t telegrams = 0;
  std::uint64_t crc_errors = 0;
  std::uint64_t resyncs = 0;        // times bytes had to be skipped to find a telegram start
  std::uint64_t skipped_bytes = 0;  // bytes discarded while resynchronising
  std::uint64_t bad_length = 0;
  std::uint64_t acks = 0, naks = 0;
};

/// Incremental telegram parser over a byte stream. Feed it any chunking of bytes; it
/// yields each CRC-valid telegram addressed as `expected_address` (0x80 for replies,
/// 0x00 for requests), and lone ACK/NAK bytes between telegrams. After garbage or a bad
/// CRC it resynchronises on the next STX+address pair. Fixed buffer; never allocates.
class Parser {
 public:
  enum class Event { kNone, kTelegram, kAckByte, kNakByte };
  explicit Parser(std::uint8_t expected_address) : address_(expected_address) {}

  /// Consumes bytes until one event is ready; returns it and how many bytes were used.
  /// Call again with the rest. `telegram()` is valid until the next call.
  Event feed(std::span<const std::uint8_t> bytes, std::size_t* consumed);
  const Telegram& telegram() const { return telegram_; }
  const ParserCounters& counters() const { return counters_; }
  /// Discards a partial telegram (e.g. after a baud change).
  void reset() {
    have_ = 0;
    delivered_ = false;
  }
  /// True while in the middle of a telegram.
  bool in_telegram() const { return have_ > 0; }

 private:
  bool try_complete();
  void resync();
  std::uint8_t address_;
  std::array<std::uint8_t, kMaxTelegram> buf_{};
  std::size_t have_ = 0;
  bool skipping_ = false;
  bool delivered_ = false;
  Telegram telegram_;
  ParserCounters counters_;
};

}  // namespace cairn::lms

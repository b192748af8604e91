// One byte-stream interface for every serial link: a real UART (libserialport), a plain
// file descriptor or pty (benches), a TCP client (serial device servers such as ser2net).
// The backend is chosen by a URI:
//
//   serial:/dev/ttyUSB0     libserialport, 8N1, no flow control; baud settable
//   tty:/dev/pts/3          termios on a plain fd (ptys, UARTs libserialport cannot see)
//   tcp:HOST:PORT           raw TCP; the device server's baud is fixed (set out of band)
//
// Reads and writes take a timeout and never block longer; after construction nothing
// allocates (the I/O thread calls them in its loop); neither do set_baud() and reopen().
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "common/clock.hpp"
#include "common/io_error.hpp"

namespace cairn::serial {

struct IoResult {
  enum class Status : std::uint8_t { kOk, kTimeout, kClosed, kError };
  Status status = Status::kOk;
  std::size_t bytes = 0;
  int error = 0;  // errno, for kError
  bool ok() const { return status == Status::kOk; }
};

class ByteStream {
 public:
  virtual ~ByteStream() = default;
  /// Reads what is available (at least 1 byte), waiting at most `timeout`.
  virtual IoResult read(std::span<std::uint8_t> buffer, Nanos timeout) = 0;
  /// Writes everything, waiting at most `timeout` in total.
  virtual IoResult write(std::span<const std::uint8_t> bytes, Nanos timeout) = 0;
  /// Changes the line rate; an error where the link cannot (TCP: kUnsupported).
  virtual IoError set_baud(std::uint32_t baud) = 0;
  virtual bool can_set_baud() const = 0;
  virtual std::uint32_t baud() const = 0;
  /// Drops unread input.
  virtual void flush_input() = 0;
  /// Closes and opens the link again (after an unplug). Called on the I/O thread: no
  /// message is built, nothing allocates; the code says why it failed.
  virtual IoError reopen() = 0;
  virtual std::string describe() const = 0;
};

/// Opens a stream from a URI at `baud`. On failure returns nullptr and a message that
/// names the port and, for serial:, lists the ports libserialport can see.
std::unique_ptr<ByteStream> open_stream(const std::string& uri, std::uint32_t baud, std::string* error);

/// Seconds one byte takes on an 8N1 line (10 bits).
constexpr double byte_time_s(std::uint32_t baud) { return baud ? 10.0 / static_cast<double>(baud) : 0.0; }

/// Baud-aware arrival time: the latest instant the first of `bytes` bytes can have
/// arrived, given that the last of them was read at `read_time` (as ArduPilot's
/// receive_time_constraint_us). Transmission of N bytes takes N byte times.
constexpr Nanos first_byte_time(Nanos read_time, std::size_t bytes, std::uint32_t baud) {
  return read_time - static_cast<Nanos>(static_cast<double>(bytes) * byte_time_s(baud) * 1e9);
}

/// The ports libserialport can see, comma separated (for error messages and the probe tool).
std::string list_serial_ports();

}  // namespace cairn::serial

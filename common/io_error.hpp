// One error vocabulary for the robot's I/O paths after start-up (a link's reopen, a baud
// change, a CAN port's restart): a code with a static message and the errno behind it.
// Nothing here allocates, so an I/O thread can report a failure without a std::string.
// Opening a device at start-up may still explain itself at length (ports found, URIs).
#pragma once

#include <cstdint>

namespace cairn {

enum class IoErrc : std::uint8_t {
  kOk,
  kNotFound,     // no such device or port (unplugged)
  kBusy,         // held by another process
  kPermission,   // not allowed to open it
  kRefused,      // the peer refused the connection
  kConnecting,   // a non-blocking connect is under way: try again later
  kUnreachable,  // no route, or the peer did not answer in time
  kLinkDown,     // the network interface is down
  kBusOff,       // the CAN controller is still bus-off
  kUnsupported,  // the link cannot do this (a baud change over TCP)
  kBadBaud,      // a rate the link or the OS cannot set
  kNotATerminal, // a tty: path that is no terminal
  kSystem,       // another errno: see `sys`
};

/// "device not found", "connection refused", ...: a static string.
const char* io_errc_text(IoErrc code);

struct IoError {
  IoErrc code = IoErrc::kOk;
  int sys = 0;  // the errno, where there was one
  constexpr bool ok() const { return code == IoErrc::kOk; }
  /// The errno's text where there is one, else ""; static (strerrordesc_np), never allocated.
  const char* sys_text() const;
};

/// The code a failure's errno means (never kOk: 0 gives kSystem).
IoError io_error_from_errno(int e);

}  // namespace cairn

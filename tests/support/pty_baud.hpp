// Whether this machine's tty layer carries a baud rate through a pty: the LMS emulator
// learns the host's line speed from the pty's termios, as a real device would hear it.
// qemu-user 7.2 (Debian bookworm) translates termios speeds only up to B460800; B500000
// reads back as 0 there, so the 500 kBd pty cases cannot run under emulation.
#pragma once

#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <string>

namespace cairn::testing {

inline bool pty_carries_500k(std::string* why) {
  int master = -1, slave = -1;
  if (openpty(&master, &slave, nullptr, nullptr, nullptr) != 0) {
    *why = "openpty failed";
    return false;
  }
  termios t{};
  tcgetattr(slave, &t);
  cfmakeraw(&t);
  cfsetspeed(&t, B500000);
  tcsetattr(slave, TCSANOW, &t);
  termios seen{};
  const bool ok = tcgetattr(master, &seen) == 0 && cfgetispeed(&seen) == B500000;
  ::close(slave);
  ::close(master);
  if (!ok) *why = "this tty layer does not carry 500 kBd through a pty (qemu-user's termios table stops at B460800)";
  return ok;
}

}  // namespace cairn::testing

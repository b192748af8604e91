#include "drivers/serial/sp_stream.hpp"

#include <fcntl.h>
#include <libserialport.h>
#include <termios.h>

#include <cerrno>
#include <cstring>

#include "drivers/serial/fd_stream.hpp"

namespace cairn::serial {

std::string list_serial_ports() {
  sp_port** ports = nullptr;
  if (sp_list_ports(&ports) != SP_OK) return "(libserialport cannot list ports)";
  std::string out;
  for (int i = 0; ports[i]; ++i) out += (out.empty() ? "" : ", ") + std::string(sp_get_port_name(ports[i]));
  sp_free_port_list(ports);
  return out.empty() ? "(none)" : out;
}

std::unique_ptr<SerialPortStream> SerialPortStream::open(const std::string& name, std::uint32_t baud, std::string* error) {
  std::unique_ptr<SerialPortStream> s(new SerialPortStream(name, baud));
  // Found once, here: sp_get_port_by_name allocates the port's record, which every
  // reopen (on the I/O thread) then reuses.
  if (sp_get_port_by_name(name.c_str(), &s->port_) != SP_OK) {
    s->port_ = nullptr;
    *error = "serial:" + name + ": no such serial port (libserialport sees: " + list_serial_ports() + ")";
    return nullptr;
  }
  if (const IoError e = s->open_port(); !e.ok()) {
    *error = "serial:" + name + ": cannot open: " + io_errc_text(e.code) + (e.sys ? std::string(" (") + e.sys_text() + ")" : "") +
             " (libserialport sees: " + list_serial_ports() + ")";
    return nullptr;
  }
  return s;
}

SerialPortStream::~SerialPortStream() {
  close_port();
  if (port_) sp_free_port(port_);
}

void SerialPortStream::close_port() {
  if (fd_ >= 0) sp_close(port_);
  fd_ = -1;
}

IoError SerialPortStream::open_port() {
  close_port();
  if (const sp_return r = sp_open(port_, SP_MODE_READ_WRITE); r != SP_OK) {
    return r == SP_ERR_FAIL ? io_error_from_errno(sp_last_error_code()) : IoError{IoErrc::kSystem, 0};
  }
  if (sp_set_bits(port_, 8) != SP_OK || sp_set_parity(port_, SP_PARITY_NONE) != SP_OK ||
      sp_set_stopbits(port_, 1) != SP_OK || sp_set_flowcontrol(port_, SP_FLOWCONTROL_NONE) != SP_OK ||
      sp_set_baudrate(port_, static_cast<int>(baud_)) != SP_OK) {
    const IoError e{IoErrc::kBadBaud, errno};
    sp_close(port_);
    return e;
  }
  // Stream on the descriptor: poll()/read()/write() honour a zero timeout and allocate nothing.
  int fd = -1;
  const int flags = sp_get_port_handle(port_, &fd) == SP_OK && fd >= 0 ? fcntl(fd, F_GETFL) : -1;
  if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0) {
    const IoError e{IoErrc::kSystem, errno};
    sp_close(port_);
    return e;
  }
  fd_ = fd;
  return {};
}

IoError SerialPortStream::set_baud(std::uint32_t baud) {
  if (fd_ < 0) return {IoErrc::kNotFound, 0};
  if (sp_set_baudrate(port_, static_cast<int>(baud)) != SP_OK) return {IoErrc::kBadBaud, errno};
  baud_ = baud;
  return {};
}

IoResult SerialPortStream::read(std::span<std::uint8_t> buffer, Nanos timeout) {
  if (fd_ < 0) return {IoResult::Status::kClosed, 0, EBADF};
  return fd_read(fd_, buffer, timeout);
}

IoResult SerialPortStream::write(std::span<const std::uint8_t> bytes, Nanos timeout) {
  if (fd_ < 0) return {IoResult::Status::kClosed, 0, EBADF};
  return fd_write(fd_, bytes, timeout);
}

void SerialPortStream::flush_input() {
  if (fd_ >= 0) tcflush(fd_, TCIFLUSH);  // sp_flush does the same
}

IoError SerialPortStream::reopen() { return open_port(); }

// ---------------------------------------------------------------- URIs

std::unique_ptr<ByteStream> open_stream(const std::string& uri, std::uint32_t baud, std::string* error) {
  const auto colon = uri.find(':');
  if (colon == std::string::npos) {
    *error = "'" + uri + "': expected serial:DEVICE, tty:PATH or tcp:HOST:PORT";
    return nullptr;
  }
  const std::string scheme = uri.substr(0, colon), rest = uri.substr(colon + 1);
  if (scheme == "serial") return SerialPortStream::open(rest, baud, error);
  if (scheme == "tty") return TtyStream::open(rest, baud, error);
  if (scheme == "tcp") {
    const auto c = rest.rfind(':');
    if (c == std::string::npos || c == 0 || c + 1 == rest.size()) {
      *error = "'" + uri + "': expected tcp:HOST:PORT";
      return nullptr;
    }
    return TcpStream::open(rest.substr(0, c), rest.substr(c + 1), baud, error);
  }
  *error = "'" + uri + "': unknown scheme '" + scheme + "' (expected serial:, tty: or tcp:)";
  return nullptr;
}

}  // namespace cairn::serial

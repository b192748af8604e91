#include "drivers/serial/sp_stream.hpp"

#include <fcntl.h>
#include <libserialport.h>

#include <cerrno>
#include <cstring>

#include "drivers/serial/fd_stream.hpp"

namespace cairn::serial {

namespace {
std::string sp_message(const std::string& what) {
  char* msg = sp_last_error_message();
  std::string s = what + ": " + (msg ? msg : "unknown error");
  if (msg) sp_free_error_message(msg);
  return s;
}
}  // namespace

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
  if (!s->open_port(error)) return nullptr;
  return s;
}

SerialPortStream::~SerialPortStream() { close_port(); }

void SerialPortStream::close_port() {
  if (port_) {
    sp_close(port_);
    sp_free_port(port_);
  }
  port_ = nullptr;
  fd_ = -1;
}

bool SerialPortStream::open_port(std::string* error) {
  close_port();
  if (sp_get_port_by_name(name_.c_str(), &port_) != SP_OK) {
    port_ = nullptr;
    *error = "serial:" + name_ + ": no such serial port (libserialport sees: " + list_serial_ports() + ")";
    return false;
  }
  if (sp_open(port_, SP_MODE_READ_WRITE) != SP_OK) {
    *error = sp_message("serial:" + name_ + ": cannot open (busy, or no permission?)") +
             " (libserialport sees: " + list_serial_ports() + ")";
    close_port();
    return false;
  }
  if (sp_set_bits(port_, 8) != SP_OK || sp_set_parity(port_, SP_PARITY_NONE) != SP_OK ||
      sp_set_stopbits(port_, 1) != SP_OK || sp_set_flowcontrol(port_, SP_FLOWCONTROL_NONE) != SP_OK) {
    *error = sp_message("serial:" + name_ + ": cannot configure 8N1 without flow control");
    close_port();
    return false;
  }
  if (!set_baud(baud_, error)) {
    close_port();
    return false;
  }
  // Stream on the descriptor: poll()/read()/write() honour a zero timeout and allocate nothing.
  int fd = -1;
  const int flags = sp_get_port_handle(port_, &fd) == SP_OK && fd >= 0 ? fcntl(fd, F_GETFL) : -1;
  if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0) {
    *error = "serial:" + name_ + ": no usable file descriptor from libserialport";
    close_port();
    return false;
  }
  fd_ = fd;
  return true;
}

bool SerialPortStream::set_baud(std::uint32_t baud, std::string* error) {
  if (!port_ || sp_set_baudrate(port_, static_cast<int>(baud)) != SP_OK) {
    *error = port_ ? sp_message("serial:" + name_ + ": cannot set " + std::to_string(baud) + " baud")
                   : "serial:" + name_ + ": not open";
    return false;
  }
  baud_ = baud;
  return true;
}

IoResult SerialPortStream::read(std::span<std::uint8_t> buffer, Nanos timeout) {
  if (!port_) return {IoResult::Status::kClosed, 0, EBADF};
  return fd_read(fd_, buffer, timeout);
}

IoResult SerialPortStream::write(std::span<const std::uint8_t> bytes, Nanos timeout) {
  if (!port_) return {IoResult::Status::kClosed, 0, EBADF};
  return fd_write(fd_, bytes, timeout);
}

void SerialPortStream::flush_input() {
  if (port_) sp_flush(port_, SP_BUF_INPUT);
}

bool SerialPortStream::reopen(std::string* error) { return open_port(error); }

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

#include "common/io_error.hpp"

#include <cerrno>
#include <cstring>

namespace cairn {

const char* io_errc_text(IoErrc code) {
  switch (code) {
    case IoErrc::kOk: return "ok";
    case IoErrc::kNotFound: return "device not found";
    case IoErrc::kBusy: return "device busy";
    case IoErrc::kPermission: return "permission denied";
    case IoErrc::kRefused: return "connection refused";
    case IoErrc::kConnecting: return "connecting (no answer yet)";
    case IoErrc::kUnreachable: return "peer unreachable";
    case IoErrc::kLinkDown: return "link down";
    case IoErrc::kBusOff: return "bus-off persists";
    case IoErrc::kUnsupported: return "not supported by this link";
    case IoErrc::kBadBaud: return "baud rate not settable";
    case IoErrc::kNotATerminal: return "not a terminal";
    case IoErrc::kSystem: return "system error";
  }
  return "?";
}

const char* IoError::sys_text() const {
  if (sys == 0) return "";
  const char* t = strerrordesc_np(sys);  // glibc >= 2.32: a constant string, thread-safe
  return t ? t : "unknown errno";
}

IoError io_error_from_errno(int e) {
  switch (e) {
    case 0: return {IoErrc::kSystem, 0};  // a failure without an errno is still a failure
    case ENOENT:
    case ENODEV:
    case ENXIO: return {IoErrc::kNotFound, e};
    case EBUSY: return {IoErrc::kBusy, e};
    case EACCES:
    case EPERM: return {IoErrc::kPermission, e};
    case ECONNREFUSED: return {IoErrc::kRefused, e};
    case EINPROGRESS:
    case EALREADY: return {IoErrc::kConnecting, e};
    case ENETUNREACH:
    case EHOSTUNREACH:
    case ETIMEDOUT: return {IoErrc::kUnreachable, e};
    case ENETDOWN: return {IoErrc::kLinkDown, e};
    default: return {IoErrc::kSystem, e};
  }
}

}  // namespace cairn

// Errors from the Cyclone DDS C API, as exceptions that name the call and the code.
#pragma once

#include <dds/dds.h>

#include <stdexcept>
#include <string>

namespace cairn::dds {

class DdsError : public std::runtime_error {
 public:
  DdsError(const std::string& call, dds_return_t rc)
      : std::runtime_error(call + " failed: " + dds_strretcode(rc) + " (" + std::to_string(rc) + ")"), rc_(rc) {}
  dds_return_t code() const { return rc_; }

 private:
  dds_return_t rc_;
};

/// Returns rc (an entity handle or a count) or throws DdsError naming `call`.
inline dds_return_t check(dds_return_t rc, const std::string& call) {
  if (rc < 0) throw DdsError(call, rc);
  return rc;
}

}  // namespace cairn::dds

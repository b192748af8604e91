// cairn-fuzz-base's handle on the cairn-base under test: started with its output in a log
// file (read back for its counters), watched for life, stopped with SIGTERM.
#pragma once

#include <sys/types.h>

#include <string>

#include "common/clock.hpp"

namespace cairn::fuzz {

class BaseProcess {
 public:
  /// Starts `binary` (empty: found next to this program, in the build tree, else on PATH)
  /// with `--config config`; stdout and stderr go to `log_path`. Throws if it cannot start.
  BaseProcess(std::string binary, const std::string& config, std::string log_path);
  ~BaseProcess();
  BaseProcess(const BaseProcess&) = delete;
  BaseProcess& operator=(const BaseProcess&) = delete;

  struct Exit {
    enum Kind { kExited, kSignalled, kHung } kind = kExited;
    int code = 0;  // exit status, or the signal
    std::string describe() const;
  };

  bool wait_for_text(const std::string& needle, Nanos timeout) const;
  bool alive();
  /// SIGTERM, then waits up to `timeout`; kHung (and SIGKILL) if it did not stop by then.
  Exit stop(Nanos timeout);
  std::string log() const;
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  std::string log_path_;
  bool reaped_ = false;
  int status_ = 0;
};

}  // namespace cairn::fuzz

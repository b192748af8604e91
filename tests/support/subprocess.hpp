// Test support: run a program as a child process, read its output line by line
// with a timeout, signal it, reap it.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace cairn::testing {

class Subprocess {
 public:
  /// Starts argv[0] with the given arguments; stdout and stderr go to one pipe we read.
  explicit Subprocess(const std::vector<std::string>& argv);
  ~Subprocess();
  Subprocess(const Subprocess&) = delete;
  Subprocess& operator=(const Subprocess&) = delete;

  /// Reads output until a line containing `needle` arrives or the timeout passes.
  /// Returns the line, or nullopt on timeout / end of output.
  std::optional<std::string> wait_for_line(const std::string& needle, std::chrono::milliseconds timeout);
  /// Waits until `needle` appears anywhere in the output so far (order-independent).
  bool wait_for_text(const std::string& needle, std::chrono::milliseconds timeout);
  /// Everything read so far.
  const std::string& output() const { return output_; }
  void signal(int sig);
  /// Waits for exit; returns the exit status (or 128+signal), or -1 on timeout.
  int wait(std::chrono::milliseconds timeout);
  pid_t pid() const { return pid_; }

 private:
  bool read_some(int timeout_ms);
  pid_t pid_ = -1;
  int fd_ = -1;
  std::string output_;
  std::size_t scanned_ = 0;  // start of the first line not yet matched
  bool reaped_ = false;
  int status_ = 0;
};

}  // namespace cairn::testing

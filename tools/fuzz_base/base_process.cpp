#include "tools/fuzz_base/base_process.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <cstring>
#include <stdexcept>

namespace cairn::fuzz {

namespace {

std::string find_base(std::string binary) {
  if (!binary.empty()) return binary;
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec).parent_path();
  for (const auto& candidate : {self / "cairn-base", self / ".." / ".." / "basestation" / "cairn-base"}) {
    if (std::filesystem::exists(candidate, ec)) return candidate.string();
  }
  return "cairn-base";  // execvp searches PATH
}

BaseProcess::Exit decode(int status) {
  if (WIFEXITED(status)) return {BaseProcess::Exit::kExited, WEXITSTATUS(status)};
  return {BaseProcess::Exit::kSignalled, WTERMSIG(status)};
}

}  // namespace

BaseProcess::BaseProcess(std::string binary, const std::string& config, std::string log_path) : log_path_(std::move(log_path)) {
  binary = find_base(std::move(binary));
  const int fd = ::open(log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot create " + log_path_);
  pid_ = ::fork();
  if (pid_ < 0) {
    ::close(fd);
    throw std::runtime_error("fork failed");
  }
  if (pid_ == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // no orphaned base if the fuzzer dies
    ::dup2(fd, STDOUT_FILENO);
    ::dup2(fd, STDERR_FILENO);
    const char* argv[] = {binary.c_str(), "--config", config.c_str(), nullptr};
    ::execvp(argv[0], const_cast<char* const*>(argv));
    const std::string msg = "cannot run " + binary + "\n";
    (void)!::write(STDERR_FILENO, msg.data(), msg.size());
    ::_exit(127);
  }
  ::close(fd);
}

BaseProcess::~BaseProcess() {
  if (!reaped_ && pid_ > 0) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
}

std::string BaseProcess::log() const {
  std::ifstream in(log_path_);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool BaseProcess::wait_for_text(const std::string& needle, Nanos timeout) const {
  auto& clock = MonotonicClock::instance();
  const Nanos deadline = clock.now() + timeout;
  while (clock.now() < deadline) {
    if (log().find(needle) != std::string::npos) return true;
    clock.sleep_until(clock.now() + 50 * kNanosPerMilli);
  }
  return false;
}

bool BaseProcess::alive() {
  if (reaped_) return false;
  if (::waitpid(pid_, &status_, WNOHANG) == pid_) reaped_ = true;
  return !reaped_;
}

std::string BaseProcess::Exit::describe() const {
  switch (kind) {
    case kExited: return "exited with status " + std::to_string(code);
    case kSignalled: return "killed by signal " + std::to_string(code) + " (" + strsignal(code) + ")";
    case kHung: return "did not stop after SIGTERM (killed)";
  }
  return "?";
}

BaseProcess::Exit BaseProcess::stop(Nanos timeout) {
  if (!alive()) return decode(status_);
  ::kill(pid_, SIGTERM);
  auto& clock = MonotonicClock::instance();
  const Nanos deadline = clock.now() + timeout;
  while (clock.now() < deadline) {
    if (!alive()) return decode(status_);
    clock.sleep_until(clock.now() + 20 * kNanosPerMilli);
  }
  ::kill(pid_, SIGKILL);
  ::waitpid(pid_, &status_, 0);
  reaped_ = true;
  return {Exit::kHung, 0};
}

}  // namespace cairn::fuzz

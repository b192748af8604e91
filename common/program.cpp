#include "common/program.hpp"

#include <csignal>
#include <cstdio>
#include <exception>

#include "common/config.hpp"
#include "common/log.hpp"

namespace cairn {

namespace {
std::atomic<bool> g_shutdown{false};
extern "C" void on_signal(int) { g_shutdown.store(true); }
}  // namespace

bool shutdown_requested() { return g_shutdown.load(std::memory_order_relaxed); }
void request_shutdown() { g_shutdown.store(true); }

void install_shutdown_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
}

int run_program(const char* program, const std::function<int()>& body) {
  try {
    return body();
  } catch (const ConfigError& e) {
    logger().stop();
    std::fprintf(stderr, "%s: configuration error: %s\n", program, e.what());
    return 2;
  } catch (const std::exception& e) {
    logger().stop();
    std::fprintf(stderr, "%s: error: %s\n", program, e.what());
    return 1;
  }
}

}  // namespace cairn

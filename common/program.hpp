// What every Cairn program does around main(): a clean shutdown flag set by
// SIGINT/SIGTERM, and errors reported as one clear line with a non-zero exit.
#pragma once

#include <atomic>
#include <functional>
#include <string>

namespace cairn {

/// True once SIGINT or SIGTERM arrived (after install_shutdown_handlers()).
bool shutdown_requested();
void request_shutdown();
void install_shutdown_handlers();

/// Runs body; a ConfigError exits 2, any other exception 1, each printed as "PROGRAM: error: WHAT".
int run_program(const char* program, const std::function<int()>& body);

}  // namespace cairn

// cairn-lms-probe: what a technician runs on a robot to check its SICK LMS2xx. Connects to
// a URI, brings the scanner to streaming with the production driver, prints the scanner's
// type and the driver's state, then N scans (one line each) or a rate summary.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <vector>

#include "common/program.hpp"
#include "drivers/serial/byte_stream.hpp"
#include "drivers/sick/lms_driver.hpp"

using namespace cairn;

namespace {

struct Printer : lms::ScanSink {
  bool quiet = false;
  std::uint64_t n = 0;
  Nanos first = 0, last = 0;
  void on_scan(const lms::LmsScan& s) override {
    if (n++ == 0) first = s.first_byte_time;
    last = s.first_byte_time;
    if (quiet) return;
    int returns = 0, reflective = 0;
    std::uint16_t lo = 0xFFFF, hi = 0;
    for (int i = 0; i < s.count; ++i) {
      if (!s.range_mm[i]) continue;
      ++returns;
      reflective += s.flags[i] != 0;
      lo = std::min(lo, s.range_mm[i]);
      hi = std::max(hi, s.range_mm[i]);
    }
    std::printf("scan %5u  t=%.6f s  %3u beams  %3d returns  range %.3f..%.3f m  %d reflective\n", s.seq,
                nanos_to_seconds(s.stamp), s.count, returns, returns ? lo / 1000.0 : 0.0, returns ? hi / 1000.0 : 0.0,
                reflective);
  }
};

int run(const std::string& uri, std::uint32_t baud, std::uint32_t target, int angle, int resolution, int scans, double rate_s,
        double timeout_s) {
  std::string err;
  auto stream = serial::open_stream(uri, baud, &err);
  if (!stream) throw std::runtime_error(err);
  std::printf("probe: %s opened at %u baud\n", stream->describe().c_str(), baud);
  lms::LmsDriverConfig cfg;
  cfg.target_baud = target;
  cfg.angle_deg = static_cast<std::uint16_t>(angle);
  cfg.resolution_centideg = static_cast<std::uint16_t>(resolution);
  Printer printer;
  printer.quiet = rate_s > 0;
  auto& clock = MonotonicClock::instance();
  lms::LmsDriver driver(stream.get(), &clock, cfg, &printer);
  const Nanos start = clock.now();
  lms::DriverState shown = driver.state();
  std::string last_reason;
  bool announced = false;
  while (!shutdown_requested()) {
    driver.step();
    const Nanos now = clock.now();
    if (driver.reason() != last_reason) {
      last_reason = driver.reason();
      std::printf("probe: [%7.3f s] %-11s %s\n", nanos_to_seconds(now - start), lms::state_name(driver.state()),
                  last_reason.c_str());
      shown = driver.state();
    }
    if (driver.state() == lms::DriverState::kStreaming && !announced) {
      announced = true;
      std::printf("probe: scanner type '%s'\n", driver.device_type());
    }
    if (!announced && now - start > seconds_to_nanos(timeout_s)) {
      std::printf("probe: no scanner streaming after %.1f s on %s (last state: %s: %s)\n", timeout_s, uri.c_str(),
                  lms::state_name(shown), driver.reason());
      return 3;
    }
    if (rate_s <= 0 && printer.n >= static_cast<std::uint64_t>(scans)) break;
    if (rate_s > 0 && announced && now - start > seconds_to_nanos(rate_s) + seconds_to_nanos(timeout_s)) break;
    if (rate_s > 0 && announced && printer.n > 1 && nanos_to_seconds(printer.last - printer.first) >= rate_s) break;
  }
  const lms::LmsCounters& c = driver.counters();
  if (printer.n > 1) {
    std::printf("probe: %llu scans, %.2f Hz\n", static_cast<unsigned long long>(printer.n),
                static_cast<double>(printer.n - 1) / nanos_to_seconds(printer.last - printer.first));
  }
  std::printf("probe: counters: crc errors %llu, resyncs %llu, timeouts %llu, reconnects %llu, NAKs %llu, bad scans %llu\n",
              static_cast<unsigned long long>(c.crc_errors), static_cast<unsigned long long>(c.resyncs),
              static_cast<unsigned long long>(c.timeouts), static_cast<unsigned long long>(c.reconnects),
              static_cast<unsigned long long>(c.naks), static_cast<unsigned long long>(c.bad_scans));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-lms-probe: connect to a SICK LMS2xx, bring it to streaming, print its type, state and scans.\n"
               "Examples:  cairn-lms-probe --uri serial:/dev/ttyUSB0 --scans 5\n"
               "           cairn-lms-probe --uri tcp:192.0.2.7:4001 --baud 38400 --target-baud 38400 --rate 10"};
  std::string uri;
  int baud = 9600, target = 500000, angle = 180, resolution = 50, scans = 10;
  double rate = 0, timeout = 10;
  app.add_option("-u,--uri", uri, "serial:/dev/ttyUSB0, tty:/dev/pts/N or tcp:HOST:PORT")->required();
  const std::vector<std::uint32_t> rates(lms::kBauds.begin(), lms::kBauds.end());
  app.add_option("--baud", baud, "host baud rate to open with (the driver searches all four anyway)")->check(CLI::IsMember(rates));
  app.add_option("--target-baud", target, "baud rate to switch the scanner to (38400 for RS-232 adapters)")
      ->check(CLI::IsMember(rates));
  app.add_option("--angle", angle, "scanning field in degrees: 100 or 180");
  app.add_option("--resolution", resolution, "angular resolution in 1/100 degree: 100, 50 or 25 (25: 100 degree field only)");
  app.add_option("-n,--scans", scans, "print this many scans, then exit")->check(CLI::PositiveNumber);
  app.add_option("--rate", rate, "instead of printing scans, measure the scan rate over this many seconds");
  app.add_option("--timeout", timeout, "give up if not streaming after this many seconds");
  CLI11_PARSE(app, argc, argv);
  // The scanner's own rule (lms::valid_variant), as the driver's config and the emulator use it.
  if (angle < 0 || angle > 0xFFFF || resolution < 0 || resolution > 0xFFFF ||
      !lms::valid_variant(static_cast<std::uint16_t>(angle), static_cast<std::uint16_t>(resolution))) {
    std::fprintf(stderr, "cairn-lms-probe: --angle %d --resolution %d is not a variant an LMS2xx offers "
                 "(100 degrees at 100, 50 or 25; 180 degrees at 100 or 50)\n", angle, resolution);
    return 2;
  }
  if (uri.rfind("serial:", 0) == 0 && uri == "serial:") std::printf("ports: %s\n", serial::list_serial_ports().c_str());
  install_shutdown_handlers();
  return run_program("cairn-lms-probe", [&] {
    return run(uri, static_cast<std::uint32_t>(baud), static_cast<std::uint32_t>(target), angle, resolution, scans, rate, timeout);
  });
}

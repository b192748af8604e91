// cairn-record: writes every Cairn topic to an MCAP file (docs/recording.md).
#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <ctime>

#include "common/clock.hpp"
#include "common/dds/participant.hpp"
#include "common/program.hpp"
#include "tools/mcap/mcap_writer.hpp"
#include "tools/recording/profile_choice.hpp"
#include "tools/recording/recorder.hpp"

using namespace cairn;

namespace {

std::string default_name() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, "cairn-%Y%m%dT%H%M%SZ.mcap", &tm);
  return buf;
}

double mib(std::uint64_t bytes) { return static_cast<double>(bytes) / (1024.0 * 1024.0); }

struct Options {
  std::string output, config;
  int domain = 0;
  double duration_s = 0, progress_s = 10;
  bool overwrite = false;
};

int record(const Options& o) {
  // A file-size limit must give EFBIG (reported, exit 1), not kill the recorder unannounced.
  std::signal(SIGXFSZ, SIG_IGN);
  const std::string path = o.output.empty() ? default_name() : o.output;
  mcap::Writer out(path, "", "cairn-record", o.overwrite);
  dds::Participant pp(recording::choose_profile(o.config, o.domain));
  recording::Recorder rec(pp, out);
  std::printf("record: recording every Cairn topic to %s; DDS %s\n", path.c_str(), pp.describe().c_str());
  std::fflush(stdout);
  auto& clock = MonotonicClock::instance();
  const Nanos start = clock.now();
  const Nanos end = o.duration_s > 0 ? start + seconds_to_nanos(o.duration_s) : 0;
  const Nanos progress = o.progress_s > 0 ? seconds_to_nanos(o.progress_s) : 0;
  Nanos next_progress = start + progress;
  Nanos next_flush = start + kNanosPerSecond;
  while (!shutdown_requested() && (end == 0 || clock.now() < end)) {
    rec.poll(100 * kNanosPerMilli);
    const Nanos now = clock.now();
    if (now >= next_flush) {  // at most a second of data only in memory
      out.flush();
      next_flush = now + kNanosPerSecond;
    }
    if (progress > 0 && now >= next_progress) {
      std::printf("record: %.0f s, %llu messages, %.1f MiB\n", nanos_to_seconds(now - start),
                  static_cast<unsigned long long>(out.messages()), mib(out.bytes_written()));
      std::fflush(stdout);
      next_progress = now + progress;
    }
  }
  rec.poll(0);  // what arrived since the last poll
  out.close();
  std::printf("record: wrote %s: %llu messages (%s), %.2f MiB in %.1f s; %llu instance events (dispose/no writers) not recorded\n",
              path.c_str(), static_cast<unsigned long long>(out.messages()), rec.counts().c_str(), mib(out.bytes_written()),
              nanos_to_seconds(clock.now() - start), static_cast<unsigned long long>(rec.instance_events()));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-record: records every Cairn DDS topic to an MCAP file (schemas: the Cairn IDL, messages:\n"
               "the CDR bytes as received) until SIGINT/SIGTERM or --duration; Foxglove opens the file.\n"
               "Replay it with cairn-replay. DDS: the loopback profile unless --config names a Cairn\n"
               "configuration whose [dds] section says otherwise."};
  Options o;
  app.add_option("-o,--output", o.output, "MCAP file to write (default cairn-<UTC time>.mcap here); never overwritten unless --overwrite");
  app.add_flag("--overwrite", o.overwrite, "replace an existing output file");
  app.add_option("-c,--config", o.config, "a Cairn configuration (e.g. config/base.toml): its [dds] section chooses the profile and domain");
  app.add_option("--domain", o.domain, "DDS domain of the loopback profile (without --config)")->check(CLI::Range(0, 232));
  app.add_option("--duration", o.duration_s, "stop after this many seconds (0 = until SIGINT/SIGTERM)")->check(CLI::NonNegativeNumber);
  app.add_option("--progress", o.progress_s, "print a progress line every this many seconds (0 = never)")->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  return run_program("cairn-record", [&] { return record(o); });
}

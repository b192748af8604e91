// cairn-replay: plays an MCAP recording of cairn-record back into DDS (docs/recording.md).
#include <CLI/CLI.hpp>
#include <cstdio>

#include "common/dds/participant.hpp"
#include "common/program.hpp"
#include "tools/mcap/mcap_reader.hpp"
#include "tools/recording/profile_choice.hpp"
#include "tools/recording/replayer.hpp"

using namespace cairn;

namespace {

struct Options {
  std::string input, config, rate = "1";
  int domain = 0;
  std::vector<std::string> topics, exclude;
  double wait_s = 5, progress_s = 5;
  std::uint32_t readers = 1;
};

double parse_rate(const std::string& s) {
  if (s == "max") return 0;
  std::size_t used = 0;
  double r = -1;
  try {
    r = std::stod(s, &used);
  } catch (const std::exception&) {
  }
  if (used != s.size() || !(r == 0 || (r >= 1e-3 && r <= 1e6)))
    throw std::invalid_argument("--rate: 0, 'max' or a factor in [0.001, 1e6], not '" + s + "'");
  return r;
}

int replay(const Options& o) {
  recording::ReplayOptions ro;
  ro.rate = parse_rate(o.rate);
  ro.only.insert(o.topics.begin(), o.topics.end());
  ro.exclude.insert(o.exclude.begin(), o.exclude.end());
  ro.wait_for_readers = seconds_to_nanos(o.wait_s);
  ro.min_readers = o.readers;
  ro.progress_every = seconds_to_nanos(o.progress_s);
  const mcap::File file(o.input);  // checked whole before anything is written
  dds::Participant pp(recording::choose_profile(o.config, o.domain));
  recording::Replayer player(pp, file.contents(), ro);
  std::string topics;
  for (const std::string& t : player.replayed_topics()) topics += (topics.empty() ? "" : ", ") + t;
  std::printf("replay: %s: %zu messages; replaying %s at %s; DDS %s\n", o.input.c_str(), file.contents().messages.size(),
              topics.empty() ? "no topic" : topics.c_str(), ro.rate > 0 ? (o.rate + "x").c_str() : "full speed",
              pp.describe().c_str());
  for (const std::string& n : player.notes()) std::printf("replay: %s\n", n.c_str());
  std::fflush(stdout);
  const recording::ReplayResult r = player.run([] { return shutdown_requested(); },
                                               [](const std::string& line) {
                                                 std::printf("%s\n", line.c_str());
                                                 std::fflush(stdout);
                                               });
  std::printf("replay: %s: %llu messages written (%.1f s recorded) in %.2f s, %llu not replayed, %llu rejected\n",
              r.interrupted ? "interrupted" : "done", static_cast<unsigned long long>(r.written), r.recorded_s, r.wall_s,
              static_cast<unsigned long long>(r.skipped), static_cast<unsigned long long>(r.rejected));
  if (r.rejected > 0) {
    std::fprintf(stderr, "cairn-replay: error: %llu samples rejected, the first: %s\n", static_cast<unsigned long long>(r.rejected),
                 r.first_error.c_str());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cairn-replay: plays a cairn-record MCAP file back into DDS: each message's CDR bytes on its\n"
               "topic, with the QoS the robots and the base write it with, keeping the recorded timing\n"
               "(scaled by --rate). DDS: the loopback profile unless --config says otherwise."};
  Options o;
  app.add_option("file", o.input, "MCAP file written by cairn-record")->required();
  app.add_option("--rate", o.rate, "speed factor (1 = as recorded, 10 = ten times faster; 0 or max = as fast as possible)");
  app.add_option("--topics", o.topics, "replay only these topics (comma-separated DDS names)")->delimiter(',');
  app.add_option("--exclude", o.exclude, "never replay these topics (e.g. the base's outputs when feeding a base)")->delimiter(',');
  app.add_option("-c,--config", o.config, "a Cairn configuration whose [dds] section chooses the profile and domain");
  app.add_option("--domain", o.domain, "DDS domain of the loopback profile (without --config)")->check(CLI::Range(0, 232));
  app.add_option("--wait-readers", o.wait_s, "before the first message, wait up to this many seconds for every replayed topic to have a reader")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--readers", o.readers, "the readers each replayed topic waits for (--wait-readers); 2 for a base and a recorder");
  app.add_option("--progress", o.progress_s, "print progress every this many seconds (0 = never)")->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  install_shutdown_handlers();
  return run_program("cairn-replay", [&] { return replay(o); });
}

// cairn-test-secure-probe: one DDS participant on the loopback profile, secured with a
// fleet member's keys (or not: "none"), that publishes or reads one Cairn topic for a
// bounded time and says what happened (tests/security/secure_fleet_test.cpp).
//
//   cairn-test-secure-probe KEYS|none pub|sub task|status SECONDS DOMAIN [ROBOT_ID [PARTITION_ROBOT]]
//
// A publisher stops 1 s after a reader matched. A status is keyed ROBOT_ID (default 1) and
// written in robot PARTITION_ROBOT's partition (default ROBOT_ID); a reader says how many
// samples it dropped as another robot's ("foreign").
// Exit status: 0 a reader matched (pub) / samples arrived (sub); 3 the participant was
// refused (bad or tampered keys); 4 the writer or reader was refused (permissions);
// 5 nothing matched or arrived in SECONDS; 2 bad arguments.
#include <cstdio>
#include <algorithm>
#include <cstdlib>
#include <memory>
#include <string>

#include "cairn.h"
#include "common/clock.hpp"
#include "common/dds/error.hpp"
#include "common/dds/participant.hpp"
#include "common/dds/profile.hpp"
#include "common/dds/qos.hpp"
#include "common/dds/topics.hpp"

using namespace cairn;

namespace {

template <typename T>
int publish(const dds::Participant& pp, const T& sample, std::uint16_t partition_robot, Nanos deadline) {
  std::unique_ptr<dds::Topic<T>> topic;
  std::unique_ptr<dds::Writer<T>> w;
  try {
    topic = std::make_unique<dds::Topic<T>>(pp);
    if constexpr (dds::PerRobotTopic<T>) {
      w = std::make_unique<dds::Writer<T>>(pp, *topic, dds::state_qos(1), partition_robot);
    } else {
      (void)partition_robot;
      w = std::make_unique<dds::Writer<T>>(pp, *topic, dds::state_qos(1));
    }
  } catch (const dds::DdsError& e) {
    std::printf("writer refused: %s\n", e.what());
    return 4;
  }
  bool matched = false;
  auto& clock = MonotonicClock::instance();
  Nanos end = deadline;
  while (clock.now() < end) {  // until the end, or 1 s after a reader matched (it has its samples)
    if (!matched && w->wait_for_readers(1, 20 * kNanosPerMilli)) {
      matched = true;
      end = std::min(deadline, clock.now() + kNanosPerSecond);
    }
    if (matched) dds_sleepfor(DDS_MSECS(20));
    (void)w->write(sample);
  }
  std::printf("%s, %llu written\n", matched ? "matched" : "no reader matched",
              static_cast<unsigned long long>(w->written()));
  return matched ? 0 : 5;
}

template <typename T>
int subscribe(const dds::Participant& pp, Nanos deadline) {
  std::unique_ptr<dds::Reader<T>> r;
  std::unique_ptr<dds::Topic<T>> topic;
  try {
    topic = std::make_unique<dds::Topic<T>>(pp);
    r = std::make_unique<dds::Reader<T>>(pp, *topic, dds::state_qos(1));
  } catch (const dds::DdsError& e) {
    std::printf("reader refused: %s\n", e.what());
    return 4;
  }
  std::size_t n = 0;
  auto& clock = MonotonicClock::instance();
  while (n < 3 && clock.now() < deadline) {
    (void)r->wait(50 * kNanosPerMilli);
    n += r->take([](const T&, const dds_sample_info_t&) {});
  }
  std::printf("received %zu, foreign %llu\n", n, static_cast<unsigned long long>(r->foreign_samples()));
  return n > 0 ? 0 : 5;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 6) {
    std::fprintf(stderr, "usage: %s KEYS|none pub|sub task|status SECONDS DOMAIN [ROBOT_ID [PARTITION_ROBOT]]\n", argv[0]);
    return 2;
  }
  const std::string keys = argv[1], mode = argv[2], topic = argv[3];
  const double seconds = std::atof(argv[4]);
  const int domain = std::atoi(argv[5]);
  const int robot = argc > 6 ? std::atoi(argv[6]) : 1;
  const int partition_robot = argc > 7 ? std::atoi(argv[7]) : robot;
  if ((mode != "pub" && mode != "sub") || (topic != "task" && topic != "status") || !(seconds > 0) || domain < 1 ||
      domain > 230) {
    std::fprintf(stderr, "secure-probe: bad arguments\n");
    return 2;
  }
  std::unique_ptr<dds::Participant> pp;
  try {
    const dds::DdsProfile plain = dds::loopback_profile(static_cast<std::uint32_t>(domain));
    const dds::DdsProfile profile = keys == "none" ? plain : dds::secured(plain, keys);
    pp = std::make_unique<dds::Participant>(profile);
  } catch (const std::exception& e) {
    std::printf("participant refused: %s\n", e.what());
    return 3;
  }
  const Nanos deadline = MonotonicClock::instance().now() + seconds_to_nanos(seconds);
  if (topic == "task") {
    if (mode == "sub") return subscribe<cairn_TaskAssignment>(*pp, deadline);
    cairn_TaskAssignment t{};
    t.robot_id = static_cast<std::uint16_t>(robot);
    t.task_id = 7;
    return publish(*pp, t, 0, deadline);
  }
  if (mode == "sub") return subscribe<cairn_RobotStatus>(*pp, deadline);
  cairn_RobotStatus s{};
  s.robot_id = static_cast<std::uint16_t>(robot);
  dds::set_text(s.name, "probe");
  return publish(*pp, s, static_cast<std::uint16_t>(partition_robot), deadline);
}

// The technician's view: cairn-hil serves an emulated scanner, cairn-lms-probe finds it.
#include <gtest/gtest.h>
#include <signal.h>

#include "tests/support/subprocess.hpp"

namespace cairn {
namespace {

using namespace std::chrono_literals;

TEST(LmsProbe, FindsTheEmulatedScannerOverPtyAndTcp) {
  for (const bool tcp : {false, true}) {
    std::vector<std::string> args = {CAIRN_HIL_BIN, "lms", "--world", std::string(CAIRN_SOURCE_DIR_STR) + "/hil/worlds/office.world"};
    if (tcp) args.insert(args.end(), {"--tcp", "0"});
    testing::Subprocess hil(args);
    const auto line = hil.wait_for_line("LMS2xx emulator at ", 5s);
    ASSERT_TRUE(line) << hil.output();
    const auto at = line->find(" at ") + 4;
    const std::string uri = line->substr(at, line->find(' ', at) - at);
    std::vector<std::string> probe = {CAIRN_PROBE_BIN, "--uri", uri, "--scans", "3"};
    if (tcp) probe.insert(probe.end(), {"--baud", "9600", "--target-baud", "9600"});
    testing::Subprocess p(probe);
    int rc = p.wait(20s);
    if (rc < 0) {  // hung: stop it so its (buffered) output shows what it was doing
      p.signal(SIGTERM);
      p.wait(3s);
    }
    EXPECT_EQ(rc, 0) << uri << "\n" << p.output();
    EXPECT_NE(p.output().find("scanner type 'LMS291;S05"), std::string::npos) << p.output();
    EXPECT_NE(p.output().find("scan     3"), std::string::npos) << p.output();
    EXPECT_NE(p.output().find("reflective"), std::string::npos);
    hil.signal(SIGTERM);
    EXPECT_EQ(hil.wait(5s), 0) << hil.output();
  }
  testing::Subprocess bad({CAIRN_PROBE_BIN, "--uri", "serial:/dev/ttyNOPE"});
  EXPECT_EQ(bad.wait(10s), 1);
  EXPECT_NE(bad.output().find("no such serial port"), std::string::npos) << bad.output();
  // 0.25 degree exists only with the 100 degree field (lms::valid_variant, the driver's rule).
  testing::Subprocess variant({CAIRN_PROBE_BIN, "--uri", "tty:/dev/null", "--resolution", "25"});
  EXPECT_EQ(variant.wait(10s), 2);
  EXPECT_NE(variant.output().find("not a variant an LMS2xx offers"), std::string::npos) << variant.output();
}

}  // namespace
}  // namespace cairn

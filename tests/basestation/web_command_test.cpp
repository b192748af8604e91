// The web view's command parser: a visit, an exploration start/stop and an e-stop reset are
// read exactly; anything else is a clear error.
#include "basestation/web/web_command.hpp"

#include <gtest/gtest.h>

namespace cairn::base {
namespace {

TEST(WebCommand, AVisitIsReadExactly) {
  const WebCommandParse p = parse_web_command(R"({"cmd": "visit", "robot": 2, "x": -1.25, "y": 3.5})");
  ASSERT_TRUE(p.command) << p.error;
  EXPECT_EQ(p.command->kind, WebCommandKind::kVisit);
  EXPECT_EQ(p.command->robot, 2);
  EXPECT_EQ(p.command->x, -1.25);
  EXPECT_EQ(p.command->y, 3.5);
  EXPECT_EQ(p.error, "");
  EXPECT_TRUE(parse_web_command(R"({"cmd":"visit","robot":65535,"x":0,"y":0})").command);
}

TEST(WebCommand, ExploreStartStopAndAResetAreReadExactly) {
  const WebCommandParse stop = parse_web_command(R"({"cmd": "explore", "run": false})");
  ASSERT_TRUE(stop.command) << stop.error;
  EXPECT_EQ(stop.command->kind, WebCommandKind::kExplore);
  EXPECT_FALSE(stop.command->run);
  const WebCommandParse start = parse_web_command(R"({"cmd": "explore", "run": true})");
  ASSERT_TRUE(start.command) << start.error;
  EXPECT_TRUE(start.command->run);
  const WebCommandParse reset = parse_web_command(R"({"cmd": "reset", "robot": 7})");
  ASSERT_TRUE(reset.command) << reset.error;
  EXPECT_EQ(reset.command->kind, WebCommandKind::kReset);
  EXPECT_EQ(reset.command->robot, 7);
  EXPECT_STREQ(web_command_name(reset.command->kind), "reset");
  const WebCommandParse all = parse_web_command(R"({"cmd": "estop_all"})");
  ASSERT_TRUE(all.command) << all.error;
  EXPECT_EQ(all.command->kind, WebCommandKind::kEstopAll);
}

TEST(WebCommand, EverythingElseIsAClearError) {
  const auto error = [](std::string_view text) {
    const WebCommandParse p = parse_web_command(text);
    EXPECT_FALSE(p.command) << text;
    return p.error;
  };
  EXPECT_EQ(error("visit 1 2 3"), "not JSON");
  EXPECT_EQ(error(""), "not JSON");
  EXPECT_EQ(error("[1, 2]"), "expected a JSON object");
  EXPECT_EQ(error(R"({"robot": 1})"), "missing \"cmd\" (a string)");
  EXPECT_EQ(error(R"({"cmd": "estop"})"), "unknown command (known: visit, explore, reset, estop_all)");
  EXPECT_EQ(error(R"({"cmd": "explore"})"), "explore: \"run\" must be true (start) or false (stop)");
  EXPECT_EQ(error(R"({"cmd": "explore", "run": 1})"), "explore: \"run\" must be true (start) or false (stop)");
  EXPECT_EQ(error(R"({"cmd": "reset"})"), "reset: \"robot\" must be an integer 1..65535");
  EXPECT_EQ(error(R"({"cmd": "reset", "robot": 0})"), "reset: \"robot\" must be an integer 1..65535");
  EXPECT_EQ(error(R"({"cmd": "visit", "robot": 0, "x": 0, "y": 0})"), "visit: \"robot\" must be an integer 1..65535");
  EXPECT_EQ(error(R"({"cmd": "visit", "robot": 65536, "x": 0, "y": 0})"), "visit: \"robot\" must be an integer 1..65535");
  EXPECT_EQ(error(R"({"cmd": "visit", "robot": -1, "x": 0, "y": 0})"), "visit: \"robot\" must be an integer 1..65535");
  EXPECT_EQ(error(R"({"cmd": "visit", "robot": 1.5, "x": 0, "y": 0})"), "visit: \"robot\" must be an integer 1..65535");
  EXPECT_EQ(error(R"({"cmd": "visit", "robot": 18446744073709551615, "x": 0, "y": 0})"),
            "visit: \"robot\" must be an integer 1..65535");
  EXPECT_EQ(error(R"({"cmd": "visit", "robot": 1, "x": "3", "y": 0})"), "visit: \"x\" and \"y\" must be finite numbers (m)");
  EXPECT_EQ(error(R"({"cmd": "visit", "robot": 1, "x": 1e400, "y": 0})"), "not JSON");  // out of double's range
  EXPECT_EQ(error(R"({"cmd": "visit", "robot": 1, "x": 0})"), "visit: \"x\" and \"y\" must be finite numbers (m)");
  EXPECT_EQ(error(std::string(kMaxWebCommandBytes + 1, ' ')), "command longer than 1024 bytes");
  EXPECT_EQ(error(std::string(kMaxWebCommandBytes / 2, '[')), "not JSON");  // deep nesting within the cap
}

}  // namespace
}  // namespace cairn::base

#include "common/config.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace cairn {
namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(Config, ReadsTypedValuesAndSections) {
  auto doc = ConfigDocument::parse(R"(
[robot]
id = 3
name = "r3"
speed = 0.5
enabled = true
offsets = [0.1, 2, -3.5]
[[robot.device]]
uri = "tcp:127.0.0.1:4001"
[[robot.device]]
uri = "serial:/dev/ttyUSB0"
)", "robot.toml");
  const auto robot = doc.root().section("robot");
  EXPECT_EQ(robot.integer("id", {1, 250}), 3);
  EXPECT_EQ(robot.string("name"), "r3");
  EXPECT_DOUBLE_EQ(robot.number("speed", {0.0, 2.0}), 0.5);
  EXPECT_TRUE(robot.boolean("enabled"));
  EXPECT_EQ(robot.numbers("offsets", 3, 3), (std::vector<double>{0.1, 2.0, -3.5}));
  EXPECT_EQ(robot.integer_or("missing", 7), 7);
  const auto devs = robot.sections("device");
  ASSERT_EQ(devs.size(), 2u);
  EXPECT_EQ(devs[1].string("uri"), "serial:/dev/ttyUSB0");
  // device[0].uri has not been read yet: finish() must say so.
  EXPECT_THROW(doc.finish(), ConfigError);
  EXPECT_EQ(devs[0].string("uri"), "tcp:127.0.0.1:4001");
  EXPECT_NO_THROW(doc.finish());
}

TEST(Config, UnknownKeyNamesFileLineAndSuggestion) {
  auto doc = ConfigDocument::parse("[robot]\nid = 3\nnmae = \"x\"\n", "robot.toml");
  const auto robot = doc.root().section("robot");
  robot.integer("id");
  robot.string_or("name", "default");
  const std::string e = error_of([&] { doc.finish(); });
  EXPECT_NE(e.find("robot.toml:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("robot.nmae: unknown key"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'robot.name'"), std::string::npos) << e;
}

TEST(Config, UnknownSectionReportedOnce) {
  auto doc = ConfigDocument::parse("[robot]\nid = 1\n[robto]\nid = 2\nx = 1\n", "f.toml");
  doc.root().section("robot").integer("id");
  const std::string e = error_of([&] { doc.finish(); });
  EXPECT_NE(e.find("robto: unknown key"), std::string::npos) << e;
  EXPECT_EQ(e.find("robto.x"), std::string::npos) << e;
}

TEST(Config, WrongTypeAndRangeAndMissing) {
  auto doc = ConfigDocument::parse("[robot]\nid = \"three\"\nrate = 500\nmode = \"fast\"\n", "r.toml");
  const auto robot = doc.root().section("robot");
  std::string e = error_of([&] { robot.integer("id", {1, 250}); });
  EXPECT_NE(e.find("r.toml:2:"), std::string::npos) << e;
  EXPECT_NE(e.find("robot.id: expected an integer in [1, 250], got a string"), std::string::npos) << e;
  e = error_of([&] { robot.number("rate", {1.0, 200.0}); });
  EXPECT_NE(e.find("robot.rate: expected a number in [1, 200], got 500"), std::string::npos) << e;
  e = error_of([&] { robot.choice("mode", {"slow", "normal"}); });
  EXPECT_NE(e.find("expected one of \"slow\", \"normal\", got \"fast\""), std::string::npos) << e;
  e = error_of([&] { robot.integer("missing"); });
  EXPECT_NE(e.find("robot.missing: missing required key"), std::string::npos) << e;
  e = error_of([&] { doc.root().section("nope"); });
  EXPECT_NE(e.find("nope: missing required key (expected a table)"), std::string::npos) << e;
}

TEST(Config, SyntaxErrorAndMissingFile) {
  std::string e = error_of([] { ConfigDocument::parse("[robot\nid=1", "bad.toml"); });
  EXPECT_NE(e.find("bad.toml:1:"), std::string::npos) << e;
  EXPECT_NE(e.find("TOML syntax error"), std::string::npos) << e;
  e = error_of([] { ConfigDocument::load("/nonexistent/cairn.toml"); });
  EXPECT_NE(e.find("/nonexistent/cairn.toml"), std::string::npos) << e;
}

TEST(Config, NonFiniteNumbersRejected) {
  auto doc = ConfigDocument::parse("x = nan\ny = inf\n", "n.toml");
  EXPECT_NE(error_of([&] { doc.root().number("x"); }).find("expected a number"), std::string::npos);
  EXPECT_NE(error_of([&] { doc.root().number("y"); }).find("expected a number"), std::string::npos);
}

TEST(EditDistance, Basics) {
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
  EXPECT_EQ(edit_distance("", "abc"), 3u);
  EXPECT_EQ(edit_distance("same", "same"), 0u);
}

}  // namespace
}  // namespace cairn

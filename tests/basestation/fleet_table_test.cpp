// The base's fleet table admits every listed robot and a bounded number of unlisted ones:
// statuses cycling through ids (a broken or hostile publisher) are counted, not shown.
#include <gtest/gtest.h>

#include <set>

#include "basestation/fleet.hpp"

namespace cairn::base {
namespace {

TEST(FleetTable, UnlistedRobotsAreCappedAndCounted) {
  std::vector<std::string> events;
  Fleet fleet(3 * kNanosPerSecond, [&](const std::string& e) { events.push_back(e); }, FleetAdmission{{1, 2}, 2, {}});
  Nanos now = kNanosPerSecond;
  for (std::uint32_t id = 1; id <= 1000; ++id) fleet.on_status(static_cast<std::uint16_t>(id), "r", "running", 1, now);
  // Listed 1 and 2, then the first two unlisted (3, 4); 996 refused.
  ASSERT_EQ(fleet.robots().size(), 4u);
  EXPECT_TRUE(fleet.robots().contains(3));
  EXPECT_TRUE(fleet.robots().contains(4));
  EXPECT_EQ(fleet.refused(), 996u);
  // One event per admitted robot, one for the first refusal: the console is not flooded.
  EXPECT_EQ(events.size(), 5u);
  // A listed robot heard for the first time after the flood still gets its row.
  FleetAdmission late{{1, 2, 7}, 0, {}};
  Fleet fleet2(3 * kNanosPerSecond, nullptr, late);
  for (std::uint32_t id = 100; id < 200; ++id) fleet2.on_status(static_cast<std::uint16_t>(id), "x", "idle", 1, now);
  fleet2.on_status(7, "seven", "running", 1, now);
  ASSERT_EQ(fleet2.robots().size(), 1u);
  EXPECT_EQ(fleet2.robots().at(7).name, "seven");
  EXPECT_EQ(fleet2.refused(), 100u);
  // Known robots keep updating.
  fleet2.on_status(7, "seven", "stopped", 2, now + 1);
  EXPECT_EQ(fleet2.robots().at(7).messages, 2u);
}

TEST(FleetTable, AdmittedRobotsKeepTheirRowAndLostUnlistedOnesFreeTheirs) {
  std::set<std::uint16_t> fusion_admitted{50};
  Fleet fleet(3 * kNanosPerSecond, nullptr,
              FleetAdmission{{1}, 2, [&](std::uint16_t id) { return fusion_admitted.contains(id); }});
  const Nanos now = kNanosPerSecond;
  fleet.on_status(200, "spam", "running", 1, now);
  fleet.on_status(201, "spam", "running", 1, now);
  fleet.on_status(202, "spam", "running", 1, now);  // the two unlisted rows are taken: refused
  EXPECT_EQ(fleet.refused(), 1u);
  // A robot the fusion admitted gets its row although the unlisted rows are full.
  fleet.on_status(50, "unknown-but-admitted", "running", 1, now);
  EXPECT_TRUE(fleet.robots().contains(50));
  // An unlisted robot that left keeps its row until a new one needs it; a listed one keeps its row.
  fleet.on_status(1, "listed", "running", 1, now);
  fleet.on_left(200, now);
  fleet.on_lost(1, now);
  EXPECT_TRUE(fleet.robots().contains(200));
  fleet.on_status(202, "next", "running", 2, now + 1);
  EXPECT_FALSE(fleet.robots().contains(200));
  EXPECT_TRUE(fleet.robots().contains(202));
  EXPECT_TRUE(fleet.robots().contains(1));
  EXPECT_EQ(fleet.refused(), 1u);
  fleet.on_status(203, "full", "running", 1, now + 2);  // 201 and 202 alive: no room
  EXPECT_EQ(fleet.refused(), 2u);
}

}  // namespace
}  // namespace cairn::base

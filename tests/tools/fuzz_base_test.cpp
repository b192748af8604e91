// cairn-fuzz-base's parts. Its samples: reproducible from the seed, every mutation produced,
// and a sample under a real robot's id always one the base refuses as a whole (else the
// fuzz would be spoofing a robot, and the estimates check would measure the spoof). Its
// reading of the base's console line: against the line the base really prints.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

#include "basestation/base_config.hpp"
#include "basestation/explore/task_allocator.hpp"
#include "basestation/explore/visit_check.hpp"
#include "basestation/fusion_checks.hpp"
#include "basestation/fusion_node.hpp"
#include "common/dds/convert.hpp"
#include "tools/fleet_stream/fleet_scenario.hpp"
#include "tools/fuzz_base/base_summary.hpp"
#include "tools/fuzz_base/sample_mutator.hpp"

namespace cairn::fuzz {
namespace {

MutatorConfig config(std::uint64_t seed) {
  MutatorConfig c;
  c.seed = seed;
  c.fleet = {1, 2, 3};
  return c;
}

bool real(std::uint16_t id) { return id >= 1 && id <= 3; }

TEST(FuzzBaseMutator, RealRobotsOnlyGetSamplesTheBaseRefuses) {
  SampleMutator mut(config(7));
  const base::FusionLimits limits;
  auto odo = std::make_unique<cairn_OdometryIncrement>();
  auto feat = std::make_unique<cairn_FeatureObservations>();
  int real_odo = 0, real_feat = 0;
  for (int i = 0; i < 20000; ++i) {
    const Mutation mo = mut.odometry(odo.get());
    if (real(odo->robot_id)) {
      ++real_odo;
      EXPECT_TRUE(SampleMutator::refused_as_a_whole(mo)) << mutation_name(mo);
      msg::OdometryIncrement m;
      const bool clean = dds::from_dds(*odo, &m);
      EXPECT_TRUE(!clean || base::check(m, limits).has_value()) << "odometry " << i << " " << mutation_name(mo);
    }
    const Mutation mf = mut.features(feat.get());
    if (real(feat->robot_id)) {
      ++real_feat;
      EXPECT_TRUE(SampleMutator::refused_as_a_whole(mf)) << mutation_name(mf);
      msg::FeatureObservations m;
      const bool clean = dds::from_dds(*feat, &m);
      EXPECT_TRUE(!clean || base::check(m, limits).has_value()) << "features " << i << " " << mutation_name(mf);
    }
  }
  // About a fifth of each topic's samples aim at the real robots.
  EXPECT_GT(real_odo, 3000);
  EXPECT_GT(real_feat, 3000);
}

TEST(FuzzBaseMutator, ReproducibleAndCoversEveryMutation) {
  SampleMutator a(config(3)), b(config(3)), c(config(4));
  auto sa = std::make_unique<cairn_FeatureObservations>();
  auto sb = std::make_unique<cairn_FeatureObservations>();
  auto sc = std::make_unique<cairn_FeatureObservations>();
  bool all_same = true, any_differs = false;
  std::array<int, static_cast<std::size_t>(Mutation::kCount)> seen{};
  for (int i = 0; i < 5000; ++i) {
    const Mutation ma = a.features(sa.get());
    EXPECT_EQ(ma, b.features(sb.get()));
    c.features(sc.get());
    all_same = all_same && std::memcmp(sa.get(), sb.get(), sizeof *sa) == 0;
    any_differs = any_differs || std::memcmp(sa.get(), sc.get(), sizeof *sa) != 0;
    ++seen[static_cast<std::size_t>(ma)];
  }
  EXPECT_TRUE(all_same);
  EXPECT_TRUE(any_differs);
  for (std::size_t m = 0; m < seen.size(); ++m) EXPECT_GT(seen[m], 0) << mutation_name(static_cast<Mutation>(m));
}

// Visit requests never name a real robot (one would be a legitimate command, not
// malformed input); the non-finite and huge ones are what the executive's check refuses,
// the plausible ones pass it (so they test the allocator when fake robots are admitted).
TEST(FuzzBaseMutator, VisitRequestsNameOnlyFakeRobotsAndMutationsAreRefused) {
  SampleMutator mut(config(5));
  auto v = std::make_unique<cairn_VisitRequest>();
  std::array<int, static_cast<std::size_t>(Mutation::kCount)> seen{};
  for (int i = 0; i < 20000; ++i) {
    const Mutation m = mut.visit(v.get());
    ++seen[static_cast<std::size_t>(m)];
    EXPECT_FALSE(real(v->robot_id)) << i;
    EXPECT_NE(std::memchr(v->issued_by, 0, sizeof v->issued_by), nullptr) << i;  // terminated
    msg::VisitRequest r;
    (void)dds::from_dds(*v, &r);
    if (m == Mutation::kNonFinite || m == Mutation::kHuge) {
      EXPECT_NE(base::check_visit(r, true), base::VisitVerdict::kAccepted) << i << " " << mutation_name(m);
    }
    if (m == Mutation::kPlausible) {
      EXPECT_EQ(base::check_visit(r, true), base::VisitVerdict::kAccepted) << i;
    }
  }
  for (const Mutation m : {Mutation::kPlausible, Mutation::kRandomBytes, Mutation::kNonFinite, Mutation::kHuge,
                           Mutation::kSeqExtreme, Mutation::kTimeWarp}) {
    EXPECT_GT(seen[static_cast<std::size_t>(m)], 500) << mutation_name(m);
  }
}

// Bids (with their unreachable frontier clusters): the plausible ones pass the executive's
// check; the non-finite ones are refused; the time-warped ones are refused when they carry
// a negative gain or an unknown cluster kind (an item the mutator left empty has gain -0,
// which is no negative gain). Clusters are produced, and spoiled.
TEST(FuzzBaseMutator, BidsWithClustersPassOrAreRefusedByTheExecutive) {
  SampleMutator mut(config(9));
  auto d = std::make_unique<cairn_Bid>();
  explore::TaskAllocator allocator{explore::AllocatorConfig{}};
  int with_clusters = 0, spoiled_clusters = 0, bad_kinds = 0;
  for (int i = 0; i < 20000; ++i) {
    const Mutation m = mut.bid(d.get());
    msg::Bid b;
    (void)dds::from_dds(*d, &b);
    if (m != Mutation::kRandomBytes && b.n_unreachable > 0) ++with_clusters;
    const bool taken = allocator.on_bid(b, 0);
    const msg::UnreachableCluster& u = b.unreachable[0];
    if (m == Mutation::kPlausible) {
      EXPECT_TRUE(taken) << i;
    }
    if (m == Mutation::kNonFinite) {
      EXPECT_FALSE(taken) << i;
      spoiled_clusters += b.n_unreachable > 0 && (!std::isfinite(u.x) || !std::isfinite(u.y) ||
                                                  !std::isfinite(u.min_x) || !std::isfinite(u.max_y));
    }
    if (m == Mutation::kTimeWarp && b.n_unreachable > 0 && !msg::valid(u.kind)) {
      EXPECT_FALSE(taken) << i;
      ++bad_kinds;
    }
    if (m == Mutation::kTimeWarp && b.items[0].gain < 0) {
      EXPECT_FALSE(taken) << i;
    }
  }
  EXPECT_GT(with_clusters, 5000);
  EXPECT_GT(spoiled_clusters, 100);
  EXPECT_GT(bad_kinds, 100);
}

TEST(FuzzBaseMutator, SweepWalksEveryIdOutsideTheFleet) {
  MutatorConfig cfg = config(1);
  cfg.sweep_ids = true;
  SampleMutator mut(cfg);
  std::vector<bool> seen(65536, false);
  auto st = std::make_unique<cairn_RobotStatus>();
  for (int i = 0; i < 400000; ++i) {
    mut.status(st.get());
    mut.sweep(&st->robot_id);
    EXPECT_FALSE(real(st->robot_id));
    seen[st->robot_id] = true;
  }
  int n = 0;
  for (bool s : seen) n += s ? 1 : 0;
  EXPECT_EQ(n, 65536 - 3);
}

TEST(FuzzBaseMutator, RefusesFakeIdsThatOverlapTheFleet) {
  MutatorConfig c = config(1);
  c.fleet.push_back(105);
  EXPECT_THROW(SampleMutator{c}, std::invalid_argument);
  c = config(1);
  c.fake_robots = 0;
  EXPECT_THROW(SampleMutator{c}, std::invalid_argument);
}

TEST(FuzzBaseSummary, ReadsTheLineTheBasePrints) {
  const auto dir = std::filesystem::temp_directory_path() / ("cairn-fuzz-summary-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  const base::BaseConfig cfg = base::parse_base_config(
      "[dds]\nprofile = \"loopback\"\ndomain = 123\n[fusion]\nstate_dir = \"" + (dir / "state").string() +
          "\"\n[[robot]]\nid = 1\ninitial_pose = [-2.0, -1.0, 0.0]\n",
      "t.toml");
  dds::Participant pp(cfg.dds);
  base::FusionNode node(pp, cfg);
  node.restore();
  base::Fusion& fusion = const_cast<base::Fusion&>(node.fusion());  // drive it without DDS
  const auto s = fleet_stream::make_fleet_scenario(1, 40);
  for (const auto& m : s.messages) fleet_stream::feed(&fusion, m);
  msg::OdometryIncrement bad{};
  bad.robot_id = 1;
  bad.delta.x = std::numeric_limits<double>::quiet_NaN();
  fusion.on_odometry(bad);
  fusion.on_odometry(bad);
  const FusionLine f = parse_fusion_line("[   1.000] final " + node.summary());
  ASSERT_TRUE(f.parsed) << node.summary();
  EXPECT_EQ(f.odometry_applied, 40);
  EXPECT_EQ(f.features_applied, 20);
  EXPECT_EQ(f.odometry_dup, 0);
  EXPECT_EQ(f.odometry_gaps, 0);
  EXPECT_EQ(f.robots_restarted, 0);
  EXPECT_TRUE(f.finite);
  EXPECT_EQ(f.rejected.at("non_finite"), 2);
  EXPECT_FALSE(parse_fusion_line("fleet: 3 alive").parsed);
  EXPECT_EQ(last_line_with("a x\nb x\nc\n", "x"), "b x");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cairn::fuzz

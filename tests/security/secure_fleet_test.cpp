// The secure fleet on the loopback interface (issue 20 items 1, 2 and 5, first slice;
// docs/security.md): keys made by scripts/fleet-keys.sh, participants made by
// dds::secured() with a member's directory. Each case runs cairn-test-secure-probe
// processes (one identity per process: Cyclone configures a domain once per process)
// and checks what passes: the base's tasks reach a robot and a robot's status the base;
// a participant without a certificate sees nothing and commands nothing; a robot cannot
// write tasks nor the viewer anything; a revoked robot and tampered governance are refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "common/dds/profile.hpp"
#include "tests/support/subprocess.hpp"

namespace fs = std::filesystem;
using cairn::testing::Subprocess;
using namespace std::chrono_literals;

namespace {

const std::string kProbe = CAIRN_SECURE_PROBE_BIN;
// Its own domain: a plain base on domain 0 (a demo beside ctest) must not reach the
// eavesdropper below. The fleet's governance names the same domain.
const std::string kDomain = "124";
const std::string kKeys = std::string(CAIRN_SOURCE_DIR_STR) + "/scripts/fleet-keys.sh";

std::string read_file(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

int run(const std::string& cmd) { return std::system((cmd + " > /dev/null 2>&1").c_str()); }

// One fleet for the whole suite: robots 1 and 2, the base, a viewer; robot 2 revoked, with
// copies taken before (robot 2's keys, the base's with the old revocation list: the
// revoked case's control); a copy of the base's keys whose signed governance was edited,
// and an unedited copy (its control). Removed when the suite ends (it holds a CA key).
const fs::path& fleet() {
  static const fs::path dir = [] {
    const fs::path d = fs::temp_directory_path() / ("cairn-secure-fleet-" + std::to_string(getpid()));
    fs::remove_all(d);
    const std::string k = kKeys + " ";
    EXPECT_EQ(run(k + "init " + d.string() + " --domain " + kDomain), 0);
    for (const char* who : {"robot 1", "robot 2", "base", "viewer"}) EXPECT_EQ(run(k + "add " + d.string() + " " + who), 0);
    fs::copy(d / "members" / "robot-2", d / "robot-2-keys");
    fs::copy(d / "members" / "base", d / "base-old-crl");
    EXPECT_EQ(run(k + "revoke " + d.string() + " robot-2"), 0);
    fs::copy(d / "members" / "base", d / "untampered");
    fs::copy(d / "members" / "base", d / "tampered");
    std::string g = read_file(d / "tampered" / "governance.p7s");
    const std::size_t at = g.find("<data_protection_kind>ENCRYPT");
    EXPECT_NE(at, std::string::npos);
    g.replace(at, std::string("<data_protection_kind>ENCRYPT").size(), "<data_protection_kind>NONE");
    std::ofstream(d / "tampered" / "governance.p7s") << g;
    return d;
  }();
  return dir;
}

std::string member(const std::string& name) { return (fleet() / "members" / name).string(); }

struct Outcome {
  int status;
  std::string output;
};

// Two probes side by side; both are waited for.
std::pair<Outcome, Outcome> pair(const std::vector<std::string>& a, const std::vector<std::string>& b) {
  std::vector<std::string> av{kProbe}, bv{kProbe};
  av.insert(av.end(), a.begin(), a.begin() + 4);
  av.push_back(kDomain);
  av.insert(av.end(), a.begin() + 4, a.end());
  bv.insert(bv.end(), b.begin(), b.begin() + 4);
  bv.push_back(kDomain);
  bv.insert(bv.end(), b.begin() + 4, b.end());
  Subprocess pa(av), pb(bv);
  const int sa = pa.wait(30s), sb = pb.wait(30s);
  return {{sa, pa.output()}, {sb, pb.output()}};
}

Outcome one(const std::vector<std::string>& a) {
  std::vector<std::string> av{kProbe};
  av.insert(av.end(), a.begin(), a.begin() + 4);
  av.push_back(kDomain);
  av.insert(av.end(), a.begin() + 4, a.end());
  Subprocess p(av);
  const int s = p.wait(30s);
  return {s, p.output()};
}

TEST(SecureFleet, TheBasesTasksReachARobotAndARobotsStatusTheBase) {
  auto [pub, sub] = pair({member("base"), "pub", "task", "8"}, {member("robot-1"), "sub", "task", "8"});
  EXPECT_EQ(sub.status, 0) << sub.output;
  EXPECT_EQ(pub.status, 0) << pub.output;
  auto [spub, ssub] = pair({member("robot-1"), "pub", "status", "8"}, {member("base"), "sub", "status", "8"});
  EXPECT_EQ(ssub.status, 0) << ssub.output;
  EXPECT_EQ(spub.status, 0) << spub.output;
}

TEST(SecureFleet, AParticipantWithoutACertificateSeesNothingAndCommandsNothing) {
  auto [pub, eavesdropper] = pair({member("base"), "pub", "task", "4"}, {"none", "sub", "task", "4"});
  EXPECT_EQ(eavesdropper.status, 5) << eavesdropper.output;
  EXPECT_EQ(pub.status, 5) << "the base matched a reader without a certificate: " << pub.output;
  auto [intruder, robot] = pair({"none", "pub", "task", "4"}, {member("robot-1"), "sub", "task", "4"});
  EXPECT_EQ(robot.status, 5) << "a task from an intruder arrived: " << robot.output;
}

TEST(SecureFleet, ARobotCannotWriteTasksNorTheViewerAnything) {
  const Outcome robot = one({member("robot-1"), "pub", "task", "2"});
  EXPECT_EQ(robot.status, 4) << robot.output;
  EXPECT_NE(robot.output.find("writer refused"), std::string::npos) << robot.output;
  const Outcome viewer = one({member("viewer"), "pub", "status", "2"});
  EXPECT_EQ(viewer.status, 4) << viewer.output;
  const Outcome reads = one({member("robot-1"), "sub", "bid_is_not_a_probe_topic", "1"});
  EXPECT_EQ(reads.status, 2);  // the probe's own argument check, so a typo cannot pass as a refusal
}

// Issue 20: permissions grant topics, not key values, so each robot publishes in its own
// partition and only there: robot 1's keys cannot make a writer in robot 2's partition.
TEST(SecureFleet, ARobotCannotWriteInAnotherRobotsPartition) {
  const Outcome other = one({member("robot-1"), "pub", "status", "2", "2", "2"});
  EXPECT_EQ(other.status, 4) << other.output;
  EXPECT_NE(other.output.find("writer refused"), std::string::npos) << other.output;
}

// ... and a status keyed robot 2 that robot 1 writes in its own partition is dropped by the
// base's reader, counted, never delivered (robot 1's own status does arrive: the first test).
TEST(SecureFleet, AStatusKeyedToAnotherRobotNeverReachesTheBase) {
  auto [pub, base] = pair({member("robot-1"), "pub", "status", "4", "2", "1"}, {member("base"), "sub", "status", "4"});
  EXPECT_EQ(pub.status, 0) << "the base's reader did not match robot 1's writer: " << pub.output;
  EXPECT_EQ(base.status, 5) << "a status of robot 2 from robot 1 arrived: " << base.output;
  const std::smatch m = [&] {
    std::smatch r;
    std::regex_search(base.output, r, std::regex("foreign ([0-9]+)"));
    return r;
  }();
  ASSERT_FALSE(m.empty()) << base.output;
  EXPECT_GT(std::stoll(m[1]), 0) << base.output;
}

// Robot 2's own keys, kept from before the revoke: a base with the old revocation list
// takes its status (the control: the keys work), the base with the new one does not.
TEST(SecureFleet, ARevokedRobotIsRefusedByTheBase) {
  const std::string robot2 = (fleet() / "robot-2-keys").string();
  auto [cpub, old_base] = pair({robot2, "pub", "status", "8", "2"}, {(fleet() / "base-old-crl").string(), "sub", "status", "8"});
  EXPECT_EQ(old_base.status, 0) << "robot 2's keys do not work even before the revoke: " << old_base.output;
  auto [pub, base] = pair({robot2, "pub", "status", "4", "2"}, {member("base"), "sub", "status", "4"});
  EXPECT_EQ(base.status, 5) << "the revoked robot's status arrived: " << base.output;
  EXPECT_EQ(pub.status, 5) << pub.output;
  EXPECT_FALSE(fs::exists(fleet() / "revoked" / "robot-2" / "key.pem")) << "revoke keeps the dead key";
  EXPECT_TRUE(fs::exists(fleet() / "revoked" / "robot-2" / "cert.pem"));
}

// The same copy of the base's keys, unedited, starts (exit 5: nothing to read, not 3).
TEST(SecureFleet, TamperedGovernanceIsRefused) {
  const Outcome control = one({(fleet() / "untampered").string(), "sub", "task", "1"});
  EXPECT_EQ(control.status, 5) << control.output;
  const Outcome o = one({(fleet() / "tampered").string(), "sub", "task", "1"});
  EXPECT_EQ(o.status, 3) << o.output;
  EXPECT_NE(o.output.find("participant refused"), std::string::npos) << o.output;
}

TEST(SecureFleet, AKeysDirectoryWithoutItsFilesIsAClearError) {
  try {
    (void)cairn::dds::secured(cairn::dds::loopback_profile(), (fleet() / "ca").string());
    FAIL() << "accepted a directory without a member's files";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("cert.pem"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("permissions.p7s"), std::string::npos) << e.what();
  }
}

// Every Cairn topic has exactly one publishing role in the keys script (robot or base),
// so a topic added to common/dds/topics.hpp without a permission fails here.
TEST(SecureFleet, EveryTopicHasOnePublishingRoleInTheKeysScript) {
  const std::string topics = read_file(std::string(CAIRN_SOURCE_DIR_STR) + "/common/dds/topics.hpp");
  const std::string script = read_file(kKeys);
  std::set<std::string> names;
  std::set<std::string> per_robot;  // TopicTraits<T>::per_robot: a robot's, in its partition
  const std::regex topic_re("CAIRN_TOPIC\\(\\w+, \"(\\w+)\", (true|false)\\)");
  for (std::sregex_iterator it(topics.begin(), topics.end(), topic_re), end; it != end; ++it) {
    names.insert((*it)[1]);
    if ((*it)[2] == "true") per_robot.insert((*it)[1]);
  }
  ASSERT_GE(names.size(), 12u);
  auto list = [&](const std::string& var) {
    const std::regex re(var + "=\"([^\"]*)\"");
    std::smatch m;
    EXPECT_TRUE(std::regex_search(script, m, re)) << var;
    std::set<std::string> s;
    std::istringstream in(m[1]);
    for (std::string w; in >> w;) s.insert(w);
    return s;
  };
  const std::set<std::string> robot = list("robot_publishes"), base = list("base_publishes"),
                              reads = list("robot_reads");
  for (const std::string& t : names) EXPECT_EQ(robot.count(t) + base.count(t), 1u) << t;
  EXPECT_EQ(per_robot, robot) << "the topics robots publish are the per-robot ones";
  // ... in the partitions common/dds/partition.hpp names.
  const std::string partition_h = read_file(std::string(CAIRN_SOURCE_DIR_STR) + "/common/dds/partition.hpp");
  std::smatch prefix;
  ASSERT_TRUE(std::regex_search(partition_h, prefix, std::regex("kRobotPartitionPrefix = \"([^\"]*)\"")));
  EXPECT_NE(script.find("robot_partition_prefix=\"" + prefix[1].str() + "\""), std::string::npos) << prefix[1];
  for (const std::string& t : robot) EXPECT_EQ(names.count(t), 1u) << "not a Cairn topic: " << t;
  for (const std::string& t : base) EXPECT_EQ(names.count(t), 1u) << "not a Cairn topic: " << t;
  for (const std::string& t : reads) {
    EXPECT_EQ(names.count(t), 1u) << "not a Cairn topic: " << t;
    EXPECT_EQ(base.count(t), 1u) << "a robot reads " << t << ", which no role publishes";
  }
}

// The fleet's directory holds a CA key: gone when the suite ends.
class RemoveFleet : public ::testing::Environment {
 public:
  void TearDown() override { fs::remove_all(fs::temp_directory_path() / ("cairn-secure-fleet-" + std::to_string(getpid()))); }
};
const auto* const kRemoveFleet = ::testing::AddGlobalTestEnvironment(new RemoveFleet);

}  // namespace

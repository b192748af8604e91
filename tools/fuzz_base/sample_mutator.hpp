// cairn-fuzz-base's sample source: random and mutated DDS samples of every topic the base
// station reads, from a seed (reproducible). Robots of the real fleet only ever get samples
// the base must refuse as a whole (non-finite, beyond its limits, a broken covariance, a
// count beyond its array): a well-formed sample under a real robot's id would be a spoofed
// robot, which no input check can tell from the real one, not a malformed input. Plausible
// samples come from a pool of fake robots (more than the base admits) that drive, observe
// and bid, so the fuzz reaches admission, joining, relocation and the caps; the rest are
// random bytes or one mutation of a plausible sample. Enum fields always hold one of their
// values: Cyclone's serializer refuses any other (the writer fails; Debian's 0.10 also
// leaks the sample's buffer then), and its reader drops one that arrives, so an
// out-of-range enum never reaches the base.
#pragma once

#include <array>
#include <cstdint>
#include <random>
#include <vector>

#include "cairn.h"

namespace cairn::fuzz {

enum class Topic : std::uint8_t { kOdometry, kFeatures, kScan, kStatus, kBid, kVisit, kCount };
const char* topic_name(Topic t);

enum class Mutation : std::uint8_t {
  kPlausible,      // well-formed, from a fake robot
  kRandomBytes,    // every field random (strings terminated, the id never a real robot's)
  kNonFinite,      // a NaN or ±inf in a double/float field
  kHuge,           // a magnitude far beyond any limit (1e12 .. 1e300)
  kBadCovariance,  // a negative variance or an asymmetric covariance
  kCountOverflow,  // a count above its array's capacity
  kSeqExtreme,     // seq 0, UINT32_MAX or far ahead; odom_seq far ahead
  kEpochChange,    // a new boot epoch (a "restart")
  kTimeWarp,       // stamps negative, zero or far in the future
  kBadMarker,      // a robot feature naming itself, 0, or 65536 + a real robot's id
  kCount
};
const char* mutation_name(Mutation m);

struct MutatorConfig {
  std::uint64_t seed = 1;
  std::vector<std::uint16_t> fleet;  // the real robots' ids: only samples the base must refuse
  std::uint16_t first_fake_id = 100;
  std::uint16_t fake_robots = 16;
  /// Ids outside the fleet walk 0..65535 in turn instead of at random, so a run reaches
  /// every key of every topic (the most instances a reader can be made to hold).
  bool sweep_ids = false;
};

class SampleMutator {
 public:
  explicit SampleMutator(MutatorConfig cfg);

  Mutation odometry(cairn_OdometryIncrement* s);
  Mutation features(cairn_FeatureObservations* s);
  Mutation scan(cairn_LaserScan* s);
  Mutation status(cairn_RobotStatus* s);
  Mutation bid(cairn_Bid* s);
  /// An operator's visit request for a fake robot (the base refuses it unless that robot
  /// is admitted and localised; then it is the allocator's to carry out).
  Mutation visit(cairn_VisitRequest* s);

  /// The mutations a sample under a real robot's id gets (each makes the base refuse it).
  static bool refused_as_a_whole(Mutation m);
  /// With sweep_ids: every other sample under a fake robot's id takes the next id of the sweep.
  void sweep(std::uint16_t* robot_id);

 private:
  struct Fake {  // a fake robot's stream, so plausible samples follow each other
    std::uint32_t odom_seq = 0, feat_seq = 0, scan_seq = 0, status_seq = 0, bid_seq = 0;
    double x = 0, y = 0, theta = 0;
    std::int64_t t_ns = 0;
    std::uint32_t epoch = 1;
  };
  bool real(std::uint16_t id) const;
  std::uint16_t pick_fake();
  std::uint16_t pick_real();
  std::uint16_t random_non_real_id();
  Mutation pick(bool real_robot, bool has_counts, bool has_cov);
  double weird_value();
  double huge_value();
  template <typename T>
  void random_bytes(T* s);
  /// kRandomBytes: fills `s` at random under an id outside the fleet; false for any other mutation.
  template <typename T>
  bool randomised(Mutation m, T* s);
  void plausible_odometry(std::uint16_t id, cairn_OdometryIncrement* s);
  void plausible_features(std::uint16_t id, cairn_FeatureObservations* s);

  MutatorConfig cfg_;
  std::mt19937_64 rng_;
  std::vector<Fake> fakes_;
  std::uint16_t sweep_next_ = 0;
  std::uint32_t visit_seq_ = 0;
};

}  // namespace cairn::fuzz

#include "common/dds/qos.hpp"

namespace cairn::dds {

dds_qos_t* make_qos(const QosSpec& spec) {
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, spec.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT, DDS_MSECS(100));
  dds_qset_durability(q, spec.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  if (spec.depth > 0) {
    dds_qset_history(q, DDS_HISTORY_KEEP_LAST, spec.depth);
  } else {
    dds_qset_history(q, DDS_HISTORY_KEEP_ALL, DDS_LENGTH_UNLIMITED);
  }
  // What a transient-local writer keeps for readers that join later is set by the
  // durability service's history, not by the history above, and Cyclone's default for it
  // is keep-last 1: a base that restarted got each robot's last odometry sample only (a
  // gap), unless the old base's reader had left samples unacknowledged. Found by
  // netns_fleet_test's base restart; the same depth as the history now.
  if (spec.transient_local) {
    dds_qset_durability_service(q, 0, spec.depth > 0 ? DDS_HISTORY_KEEP_LAST : DDS_HISTORY_KEEP_ALL,
                                spec.depth > 0 ? spec.depth : DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED,
                                DDS_LENGTH_UNLIMITED);
  }
  // Only an explicit dispose means "gone for good"; a writer whose liveliness
  // lapses leaves its instances "no writers" so readers can tell lost from left.
  dds_qset_writer_data_lifecycle(q, false);
  if (spec.liveliness_lease > 0) dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, spec.liveliness_lease);
  return q;
}

}  // namespace cairn::dds

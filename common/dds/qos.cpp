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
  // Only an explicit dispose means "gone for good"; a writer whose liveliness
  // lapses leaves its instances "no writers" so readers can tell lost from left.
  dds_qset_writer_data_lifecycle(q, false);
  if (spec.liveliness_lease > 0) dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, spec.liveliness_lease);
  return q;
}

}  // namespace cairn::dds

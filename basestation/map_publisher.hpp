// Publishes the base's landmark map on the FeatureMap topic in pages of MAX_LANDMARKS, one
// keyed instance per page (common/idl/cairn.idl), so a map of any size reaches every reader,
// late joiners included. Pages a shrunken map no longer has are disposed.
#pragma once

#include <memory>
#include <vector>

#include "common/dds/topics.hpp"
#include "common/messages.hpp"

namespace cairn::base {

class FeatureMapPublisher {
 public:
  explicit FeatureMapPublisher(const dds::Participant& pp);
  /// Writes every page of `map` as version `seq`; returns the pages written.
  std::size_t publish(const std::vector<msg::Landmark>& map, std::uint32_t seq, Nanos stamp);

 private:
  dds::Topic<cairn_FeatureMap> topic_;
  dds::Writer<cairn_FeatureMap> writer_;
  std::size_t pages_ = 0;  // pages of the last published version
  std::unique_ptr<cairn_FeatureMap> page_ = std::make_unique<cairn_FeatureMap>();
};

}  // namespace cairn::base

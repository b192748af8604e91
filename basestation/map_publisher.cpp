#include "basestation/map_publisher.hpp"

namespace cairn::base {

FeatureMapPublisher::FeatureMapPublisher(const dds::Participant& pp) : topic_(pp), writer_(pp, topic_, dds::latched_qos()) {}

std::size_t FeatureMapPublisher::publish(const std::vector<msg::Landmark>& map, std::uint32_t seq, Nanos stamp) {
  const std::size_t pages = dds::feature_map_pages(map.size());
  for (std::size_t p = 0; p < pages; ++p) {
    dds::to_dds_page(map.data(), map.size(), p * msg::kMaxLandmarks, seq, stamp, page_.get());
    writer_.write(*page_);
  }
  for (std::size_t p = pages; p < pages_; ++p) {  // the map shrank: its old tail pages are gone
    cairn_FeatureMap key{};
    key.robot_id = 0;
    key.page = static_cast<std::uint16_t>(p);
    writer_.dispose(key);
  }
  pages_ = pages;
  return pages;
}

}  // namespace cairn::base

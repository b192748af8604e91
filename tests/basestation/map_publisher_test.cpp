// The base's FeatureMap goes out in pages (one keyed instance per page), so a map larger
// than one sample reaches a reader complete, and a late-joining reader gets all of it.
#include "basestation/map_publisher.hpp"

#include <gtest/gtest.h>

#include <map>
#include <set>

namespace cairn::base {
namespace {

constexpr std::uint32_t kDomain = 111;  // this test's own domain

std::vector<msg::Landmark> make_map(std::size_t n) {
  std::vector<msg::Landmark> m(n);
  for (std::size_t i = 0; i < n; ++i) m[i] = {static_cast<std::uint32_t>(i + 1), 0.5 * static_cast<double>(i), -0.25 * static_cast<double>(i), {0.01, 0, 0, 0.01}};
  return m;
}

/// Reads pages until every page of version `seq` is in (or the deadline passes); returns the ids.
std::set<std::uint32_t> receive(dds::Reader<cairn_FeatureMap>& reader, std::uint32_t seq, std::size_t* pages_seen) {
  std::map<std::uint16_t, std::vector<std::uint32_t>> pages;
  std::uint16_t n_pages = 0;
  const Nanos end = MonotonicClock::instance().now() + 5 * kNanosPerSecond;
  while ((n_pages == 0 || pages.size() < n_pages) && MonotonicClock::instance().now() < end) {
    reader.wait(100 * kNanosPerMilli);
    reader.take([&](const cairn_FeatureMap& s, const dds_sample_info_t&) {
      if (s.seq != seq) return;
      n_pages = s.n_pages;
      auto& ids = pages[s.page];
      ids.clear();
      for (std::size_t i = 0; i < s.n_landmarks; ++i) ids.push_back(s.landmarks[i].id);
    });
  }
  std::set<std::uint32_t> all;
  for (const auto& [p, ids] : pages) all.insert(ids.begin(), ids.end());
  *pages_seen = pages.size();
  return all;
}

TEST(FeatureMapPublisher, FiveHundredLandmarksReachALateJoiningReaderComplete) {
  dds::Participant pp(dds::loopback_profile(kDomain));
  FeatureMapPublisher pub(pp);
  const auto map = make_map(500);
  EXPECT_EQ(pub.publish(map, 7, 123), 4u);
  // The reader joins after the map was written: transient-local delivers every page.
  dds::Topic<cairn_FeatureMap> topic(pp);
  dds::Reader<cairn_FeatureMap> reader(pp, topic, dds::latched_qos());
  std::size_t pages = 0;
  const auto ids = receive(reader, 7, &pages);
  EXPECT_EQ(pages, 4u);
  ASSERT_EQ(ids.size(), 500u);
  EXPECT_EQ(*ids.begin(), 1u);
  EXPECT_EQ(*ids.rbegin(), 500u);
}

TEST(FeatureMapPublisher, AShrunkenMapDisposesItsOldPages) {
  dds::Participant pp(dds::loopback_profile(kDomain));
  FeatureMapPublisher pub(pp);
  pub.publish(make_map(300), 1, 1);  // 3 pages
  pub.publish(make_map(100), 2, 2);  // 1 page: pages 1 and 2 disposed
  dds::Topic<cairn_FeatureMap> topic(pp);
  dds::Reader<cairn_FeatureMap> reader(pp, topic, dds::latched_qos());
  std::size_t pages = 0;
  const auto ids = receive(reader, 2, &pages);
  EXPECT_EQ(pages, 1u);
  EXPECT_EQ(ids.size(), 100u);
  // Nothing of version 1 is still offered to a late joiner.
  std::size_t stale = 0;
  reader.take([&](const cairn_FeatureMap& s, const dds_sample_info_t&) { stale += s.seq == 1; });
  EXPECT_EQ(stale, 0u);
}

}  // namespace
}  // namespace cairn::base

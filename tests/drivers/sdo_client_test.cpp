// The SDO client against the emulated drive's SDO server, frame by frame (no bus): expedited
// and segmented transfers, aborts as text, timeouts with retries.
#include "drivers/canopen/sdo_client.hpp"

#include <gtest/gtest.h>

#include "drivers/canopen/object_dictionary.hpp"
#include "hil/cia402/drive_node.hpp"

namespace cairn::canopen {
namespace {

// Runs one transfer to completion between the client and the node; returns the final status.
SdoClient::Status run(SdoClient& c, hil::DriveNode& node, Nanos* now, int max_rounds = 100) {
  for (int i = 0; i < max_rounds && c.status() == SdoClient::Status::kBusy; ++i) {
    *now += kNanosPerMilli;
    if (auto f = c.poll(*now)) node.on_frame(*f, *now);
    node.update(*now);
    while (!node.outbox().empty()) {
      c.on_frame(node.outbox().front(), *now);
      node.outbox().pop_front();
    }
  }
  return c.status();
}

hil::DriveNode booted_node(Nanos* now) {
  hil::DriveConfig cfg;
  cfg.node = 3;
  cfg.boot_time_s = 0;
  hil::DriveNode n(cfg);
  n.power_on(*now);
  n.update(*now += kNanosPerMilli);
  n.outbox().clear();  // boot-up heartbeat
  return n;
}

TEST(SdoClient, ExpeditedReadAndWrite) {
  Nanos now = 0;
  hil::DriveNode node = booted_node(&now);
  SdoClient c(3, 50 * kNanosPerMilli, 2);
  ASSERT_TRUE(c.upload({od::kDeviceType, 0}));
  ASSERT_EQ(run(c, node, &now), SdoClient::Status::kDone);
  EXPECT_EQ(c.value(), 0xFFFF0192u);
  c.reset();
  ASSERT_TRUE(c.download_u32({od::kProducerHeartbeat, 0}, 100, 2));
  ASSERT_EQ(run(c, node, &now), SdoClient::Status::kDone);
  c.reset();
  ASSERT_TRUE(c.upload({od::kProducerHeartbeat, 0}));
  ASSERT_EQ(run(c, node, &now), SdoClient::Status::kDone);
  EXPECT_EQ(c.value(), 100u);
  EXPECT_EQ(c.data().size(), 2u);
}

TEST(SdoClient, SegmentedUploadOfTheDeviceName) {
  Nanos now = 0;
  hil::DriveNode node = booted_node(&now);
  SdoClient c(3, 50 * kNanosPerMilli, 2);
  ASSERT_TRUE(c.upload({od::kDeviceName, 0}));
  ASSERT_EQ(run(c, node, &now), SdoClient::Status::kDone) << c.error();
  const auto d = c.data();
  EXPECT_EQ(std::string(d.begin(), d.end()), "Cairn emulated CiA 402 drive");  // 28 bytes: 4 segments
}

TEST(SdoClient, AbortsAreDecoded) {
  Nanos now = 0;
  hil::DriveNode node = booted_node(&now);
  SdoClient c(3, 50 * kNanosPerMilli, 2);
  ASSERT_TRUE(c.upload({0x2000, 0}));
  ASSERT_EQ(run(c, node, &now), SdoClient::Status::kFailed);
  EXPECT_EQ(c.abort_code(), abort_code::kNotExist);
  EXPECT_STREQ(c.error(), "object does not exist in the object dictionary");
  c.reset();
  ASSERT_TRUE(c.download_u32({od::kStatusword, 0}, 1, 2));  // statusword is read-only
  ASSERT_EQ(run(c, node, &now), SdoClient::Status::kFailed);
  EXPECT_EQ(c.abort_code(), abort_code::kReadOnly);
  c.reset();
  ASSERT_TRUE(c.download_u32({od::kModesOfOperation, 0}, 7, 1));  // a mode the drive does not support
  ASSERT_EQ(run(c, node, &now), SdoClient::Status::kFailed);
  EXPECT_EQ(c.abort_code(), abort_code::kInvalidValue);
}

TEST(SdoClient, SilentNodeTimesOutAfterRetries) {
  Nanos now = 0;
  hil::DriveNode node = booted_node(&now);
  node.set_silent(true);
  SdoClient c(3, 20 * kNanosPerMilli, 2);
  ASSERT_TRUE(c.upload({od::kDeviceType, 0}));
  ASSERT_EQ(run(c, node, &now, 200), SdoClient::Status::kFailed);
  EXPECT_EQ(c.abort_code(), abort_code::kTimeout);  // SDO protocol timed out
  EXPECT_EQ(c.timeouts(), 3u);             // first try + 2 retries
}

TEST(SdoClient, ExtendedOrRemoteFrameOnTheResponseIdIsIgnored) {
  Nanos now = 0;
  hil::DriveNode node = booted_node(&now);
  SdoClient c(3, 50 * kNanosPerMilli, 2);
  ASSERT_TRUE(c.upload({od::kDeviceType, 0}));
  ASSERT_TRUE(c.poll(now += kNanosPerMilli));  // the request is out
  Frame junk;
  junk.len = 8;
  junk.id = 0x583 | Frame::kExtended;  // low 11 bits: node 3's SDO response
  c.on_frame(junk, now);
  junk.id = 0x583 | Frame::kRemote;
  c.on_frame(junk, now);
  EXPECT_EQ(c.status(), SdoClient::Status::kBusy) << c.error();
  c.reset();
  ASSERT_TRUE(c.upload({od::kDeviceType, 0}));
  ASSERT_EQ(run(c, node, &now), SdoClient::Status::kDone);
  EXPECT_EQ(c.value(), 0xFFFF0192u);
}

// A minimal SDO server that accepts segmented downloads, to check the client's side of them.
TEST(SdoClient, SegmentedDownload) {
  SdoClient c(5, 50 * kNanosPerMilli, 1);
  const std::string text = "robot-7 left wheel";  // 18 bytes: 3 segments
  ASSERT_TRUE(c.download({od::kDeviceName, 0}, {reinterpret_cast<const std::uint8_t*>(text.data()), text.size()}));
  std::string received;
  bool toggle = false;
  Nanos now = 0;
  for (int i = 0; i < 20 && c.status() == SdoClient::Status::kBusy; ++i) {
    now += kNanosPerMilli;
    auto f = c.poll(now);
    if (!f) continue;
    Frame r;
    const std::uint8_t ccs = f->data[0] >> 5;
    if (ccs == 1) {
      r = sdo_download_ack(5, {od::kDeviceName, 0});
    } else if (ccs == 0) {
      ASSERT_EQ(static_cast<bool>(f->data[0] & 0x10), toggle);
      const int n = 7 - ((f->data[0] >> 1) & 7);
      received.append(reinterpret_cast<const char*>(f->data.data() + 1), static_cast<std::size_t>(n));
      r = sdo_download_segment_ack(5, toggle);
      toggle = !toggle;
    }
    c.on_frame(r, now);
  }
  EXPECT_EQ(c.status(), SdoClient::Status::kDone);
  EXPECT_EQ(received, text);
}

// The server acknowledges a segment with the wrong toggle: the client fails the transfer
// AND tells the server (CiA 301: abort 0x05030000 on the client's request COB-ID).
TEST(SdoClient, DownloadToggleErrorSendsTheAbort) {
  SdoClient c(5, 50 * kNanosPerMilli, 1);
  const std::string text = "robot-7 left wheel";
  ASSERT_TRUE(c.download({od::kDeviceName, 0}, {reinterpret_cast<const std::uint8_t*>(text.data()), text.size()}));
  Nanos now = kNanosPerMilli;
  auto init = c.poll(now);
  ASSERT_TRUE(init);
  c.on_frame(sdo_download_ack(5, {od::kDeviceName, 0}), now);
  auto seg = c.poll(now += kNanosPerMilli);
  ASSERT_TRUE(seg);
  ASSERT_EQ(seg->data[0] >> 5, 0) << "first segment";
  ASSERT_FALSE(seg->data[0] & 0x10) << "first segment has toggle 0";
  c.on_frame(sdo_download_segment_ack(5, true), now);  // toggle 1: wrong
  EXPECT_EQ(c.status(), SdoClient::Status::kFailed);
  EXPECT_EQ(c.abort_code(), abort_code::kToggleBit);
  const auto abort = c.poll(now += kNanosPerMilli);
  ASSERT_TRUE(abort) << "the queued abort must go out";
  EXPECT_EQ(abort->id, 0x605u);
  const SdoResponse r = decode_sdo_response(*abort);  // same layout in both directions
  EXPECT_EQ(r.type, SdoResponse::Type::kAbort);
  EXPECT_EQ(r.abort_code, abort_code::kToggleBit);
  EXPECT_EQ(r.address.index, od::kDeviceName);
  EXPECT_FALSE(c.poll(now += kNanosPerMilli)) << "sent once";
}

TEST(SdoClient, UploadToggleErrorSendsTheAbort) {
  SdoClient c(5, 50 * kNanosPerMilli, 1);
  ASSERT_TRUE(c.upload({od::kDeviceName, 0}));
  Nanos now = kNanosPerMilli;
  ASSERT_TRUE(c.poll(now));
  c.on_frame(sdo_upload_segmented_init(5, {od::kDeviceName, 0}, 20), now);
  auto req = c.poll(now += kNanosPerMilli);
  ASSERT_TRUE(req);
  ASSERT_EQ(req->data[0], 0x60) << "upload segment request, toggle 0";
  const std::uint8_t seven[] = {'a', 'b', 'c', 'd', 'e', 'f', 'g'};
  c.on_frame(sdo_upload_segment_response(5, true, seven, false), now);  // toggle 1: wrong
  EXPECT_EQ(c.status(), SdoClient::Status::kFailed);
  EXPECT_EQ(c.abort_code(), abort_code::kToggleBit);
  const auto abort = c.poll(now += kNanosPerMilli);
  ASSERT_TRUE(abort) << "the client aborts the transfer on the bus";
  EXPECT_EQ(abort->id, 0x605u);
  EXPECT_EQ(decode_sdo_response(*abort).abort_code, abort_code::kToggleBit);
}

}  // namespace
}  // namespace cairn::canopen

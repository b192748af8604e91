// The LMS2xx codec against the telegrams in ../shared/docs/protocols.md §1.
#include "drivers/sick/lms_codec.hpp"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace cairn::lms {
namespace {

std::vector<std::uint8_t> hex(std::initializer_list<int> v) { return {v.begin(), v.end()}; }
std::vector<std::uint8_t> bytes(const Frame& f) { return {f.bytes.begin(), f.bytes.begin() + static_cast<long>(f.size)}; }

TEST(LmsCrc, MatchesEveryPublishedTelegram) {
  const std::vector<std::vector<std::uint8_t>> vectors = {
      hex({0x02, 0x00, 0x0A, 0x00, 0x20, 0x00, 0x53, 0x49, 0x43, 0x4B, 0x5F, 0x4C, 0x4D, 0x53, 0xBE, 0xC5}),
      hex({0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12}),
      hex({0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08}),
      hex({0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08}),
      hex({0x02, 0x00, 0x02, 0x00, 0x20, 0x42, 0x52, 0x08}),
      hex({0x02, 0x00, 0x02, 0x00, 0x20, 0x41, 0x51, 0x08}),
      hex({0x02, 0x00, 0x02, 0x00, 0x20, 0x40, 0x50, 0x08}),
      hex({0x02, 0x00, 0x02, 0x00, 0x20, 0x48, 0x58, 0x08}),
      hex({0x02, 0x00, 0x05, 0x00, 0x3B, 0x64, 0x00, 0x64, 0x00, 0x1D, 0x0F}),
      hex({0x02, 0x00, 0x05, 0x00, 0x3B, 0x64, 0x00, 0x32, 0x00, 0xB1, 0x59}),
      hex({0x02, 0x00, 0x05, 0x00, 0x3B, 0x64, 0x00, 0x19, 0x00, 0xE7, 0x72}),
      hex({0x02, 0x00, 0x05, 0x00, 0x3B, 0xB4, 0x00, 0x64, 0x00, 0x97, 0x49}),
      hex({0x02, 0x00, 0x05, 0x00, 0x3B, 0xB4, 0x00, 0x32, 0x00, 0x3B, 0x1F}),
      hex({0x02, 0x00, 0x02, 0x00, 0x66, 0x01, 0x9D, 0x4E}),
      hex({0x02, 0x00, 0x02, 0x00, 0x66, 0x02, 0x9E, 0x4E}),
      hex({0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A}),
      hex({0x02, 0x80, 0x07, 0x00, 0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x00, 0x13, 0x9D}),
      hex({0x02, 0x80, 0x0A, 0x00, 0xB0, 0x03, 0x40, 0xE8, 0x03, 0xD0, 0x07, 0xB8, 0x0B, 0x00, 0x32, 0x2A}),
  };
  for (const auto& v : vectors) {
    const std::uint16_t crc = crc16({v.data(), v.size() - 2});
    EXPECT_EQ(crc & 0xFF, v[v.size() - 2]);
    EXPECT_EQ(crc >> 8, v[v.size() - 1]);
  }
  // The two 0x77 configuration telegrams (mm and cm units), 32 config bytes.
  std::vector<std::uint8_t> mm = {0x02, 0x00, 0x21, 0x00, 0x77, 0, 0, 0, 0, 0, 0, 1, 0, 0, 2, 2};
  mm.resize(5 + 32, 0);
  EXPECT_EQ(crc16(mm), 0x7EFC);
  mm[11] = 0;
  EXPECT_EQ(crc16(mm), 0x72E8);
}

TEST(LmsRequests, AreByteExact) {
  EXPECT_EQ(bytes(request_installation_mode()),
            hex({0x02, 0x00, 0x0A, 0x00, 0x20, 0x00, 0x53, 0x49, 0x43, 0x4B, 0x5F, 0x4C, 0x4D, 0x53, 0xBE, 0xC5}));
  EXPECT_EQ(bytes(request_status()), hex({0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12}));
  EXPECT_EQ(bytes(request_mode(kModeStreamAll)), hex({0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08}));
  EXPECT_EQ(bytes(request_mode(kModeOnRequest)), hex({0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08}));
  EXPECT_EQ(bytes(request_mode(*baud_code(500000))), hex({0x02, 0x00, 0x02, 0x00, 0x20, 0x48, 0x58, 0x08}));
  EXPECT_EQ(bytes(request_mode(*baud_code(9600))), hex({0x02, 0x00, 0x02, 0x00, 0x20, 0x42, 0x52, 0x08}));
  EXPECT_EQ(bytes(request_variant(180, 50)), hex({0x02, 0x00, 0x05, 0x00, 0x3B, 0xB4, 0x00, 0x32, 0x00, 0x3B, 0x1F}));
  EXPECT_EQ(bytes(request_variant(100, 25)), hex({0x02, 0x00, 0x05, 0x00, 0x3B, 0x64, 0x00, 0x19, 0x00, 0xE7, 0x72}));
  const auto mm = bytes(request_write_config(ConfigBlock::millimetres().bytes));
  ASSERT_EQ(mm.size(), 39u);
  EXPECT_EQ(mm[mm.size() - 2], 0xFC);
  EXPECT_EQ(mm[mm.size() - 1], 0x7E);
  EXPECT_FALSE(baud_code(115200).has_value());
  EXPECT_EQ(baud_of_code(0x40), 38400u);
}

TEST(LmsParser, DecodesTheScanVectorInAnyChunking) {
  const auto scan = hex({0x02, 0x80, 0x0A, 0x00, 0xB0, 0x03, 0x40, 0xE8, 0x03, 0xD0, 0x07, 0xB8, 0x0B, 0x00, 0x32, 0x2A});
  for (std::size_t chunk = 1; chunk <= scan.size(); ++chunk) {
    Parser p(kReplyAddress);
    int got = 0;
    for (std::size_t off = 0; off < scan.size(); off += chunk) {
      std::span<const std::uint8_t> rest(scan.data() + off, std::min(chunk, scan.size() - off));
      while (!rest.empty()) {
        std::size_t used = 0;
        if (p.feed(rest, &used) == Parser::Event::kTelegram) {
          ScanValues v;
          ASSERT_TRUE(decode_values(p.telegram(), 0x00, &v));
          EXPECT_EQ(v.count, 3);
          EXPECT_EQ(v.units, Units::kMillimetres);
          EXPECT_EQ(v.range_mm[0], 1000);
          EXPECT_EQ(v.range_mm[1], 2000);
          EXPECT_EQ(v.range_mm[2], 3000);
          ++got;
        }
        rest = rest.subspan(used);
      }
    }
    EXPECT_EQ(got, 1) << "chunk " << chunk;
  }
}

// Feeds everything; returns the telegrams' commands and the ACK/NAK events in order.
std::vector<int> events(Parser& p, const std::vector<std::uint8_t>& stream) {
  std::vector<int> out;
  std::span<const std::uint8_t> rest(stream);
  while (!rest.empty()) {
    std::size_t used = 0;
    const auto e = p.feed(rest, &used);
    if (e == Parser::Event::kTelegram) out.push_back(p.telegram().command);
    if (e == Parser::Event::kAckByte) out.push_back(-1);
    if (e == Parser::Event::kNakByte) out.push_back(-2);
    rest = rest.subspan(used);
  }
  return out;
}

TEST(LmsParser, ResynchronisesAfterGarbageAndBadCrc) {
  const auto a0 = hex({0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A});
  auto bad = a0;
  bad[5] ^= 0x01;  // corrupt: CRC fails
  std::vector<std::uint8_t> stream = {0x06};  // ACK
  for (int g : {0x11, 0x02, 0x33, 0x02, 0x02, 0x44}) stream.push_back(static_cast<std::uint8_t>(g));  // garbage incl. stray STX
  stream.insert(stream.end(), bad.begin(), bad.end());
  stream.insert(stream.end(), a0.begin(), a0.end());
  stream.push_back(0x15);  // NAK
  stream.insert(stream.end(), a0.begin(), a0.end());
  Parser p(kReplyAddress);
  EXPECT_EQ(events(p, stream), (std::vector<int>{-1, 0xA0, -2, 0xA0}));
  EXPECT_EQ(p.counters().crc_errors, 1u);
  EXPECT_GE(p.counters().resyncs, 2u);
  EXPECT_EQ(p.counters().telegrams, 2u);
}

TEST(LmsParser, IgnoresRequestsWhenListeningForReplies) {
  // The host's own echo (address 0x00) is not a reply.
  auto stream = bytes(request_status());
  const auto a0 = hex({0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A});
  stream.insert(stream.end(), a0.begin(), a0.end());
  Parser p(kReplyAddress);
  EXPECT_EQ(events(p, stream), (std::vector<int>{0xA0}));
  Parser q(kHostAddress);
  EXPECT_EQ(events(q, bytes(request_variant(180, 50))), (std::vector<int>{kCmdVariant}));
}

TEST(LmsParser, SurvivesRandomNoiseAndFindsEveryTelegramAfterIt) {
  std::mt19937 rng(1);
  const auto a0 = hex({0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A});
  std::vector<std::uint8_t> stream;
  int planted = 0;
  for (int i = 0; i < 200; ++i) {
    for (int k = 0; k < 50; ++k) stream.push_back(static_cast<std::uint8_t>(rng() % 256));
    stream.push_back(0xFF);  // ends any accidental partial telegram...
    for (int k = 0; k < 2 * static_cast<int>(kMaxTelegram); ++k) stream.push_back(0x00);  // ... by running it out
    stream.insert(stream.end(), a0.begin(), a0.end());
    ++planted;
  }
  Parser p(kReplyAddress);
  int found = 0;
  for (int e : events(p, stream)) found += e == 0xA0;
  EXPECT_EQ(found, planted);
}

TEST(LmsValues, UnitsInterlacingFlagsAndMalformedInput) {
  Frame f;
  // 2 values in cm, partial index 2, measuring mode 0x01 (reflector levels in bits 13-15).
  const std::uint16_t word = 2 | (2 << 11) | (0 << 14);
  const std::uint16_t v0 = 150 | (5 << 13), v1 = 8191;
  const std::uint8_t data[] = {word & 0xFF, word >> 8, v0 & 0xFF, v0 >> 8, v1 & 0xFF, v1 >> 8, 0x00};
  ASSERT_TRUE(encode(kReplyAddress, kReplyValues, data, &f));
  Parser p(kReplyAddress);
  std::size_t used = 0;
  ASSERT_EQ(p.feed(f.view(), &used), Parser::Event::kTelegram);
  ScanValues v;
  ASSERT_TRUE(decode_values(p.telegram(), 0x01, &v));
  EXPECT_EQ(v.units, Units::kCentimetres);
  EXPECT_EQ(v.partial_index, 2);
  EXPECT_EQ(v.range_mm[0], 1500);
  EXPECT_EQ(v.flags[0], 5);
  EXPECT_EQ(v.range_mm[1], 65535);  // 8191 cm = 81.91 m saturates the mm field
  EXPECT_EQ(v.saturated, 1);
  // Count larger than the data: rejected, not read past the end.
  const std::uint8_t lying[] = {10, 0x40, 1, 0, 0x00};
  ASSERT_TRUE(encode(kReplyAddress, kReplyValues, lying, &f));
  Parser q(kReplyAddress);
  ASSERT_EQ(q.feed(f.view(), &used), Parser::Event::kTelegram);
  EXPECT_FALSE(decode_values(q.telegram(), 0x00, &v));
}

TEST(LmsStatus, RoundTrip) {
  StatusReply s;
  s.operating_mode = 0x24;
  s.measuring_mode = 0x00;
  s.units = 1;
  s.scan_angle = 180;
  s.resolution = 50;
  std::copy_n("V02.10 ", 7, s.version.begin());
  std::array<std::uint8_t, 153> data;
  encode_status_data(s, &data);
  Frame f;
  ASSERT_TRUE(encode(kReplyAddress, kReplyStatus, data, &f));
  EXPECT_EQ(f.size, 160u);  // Olin reads ACK + a 160-byte telegram
  Parser p(kReplyAddress);
  std::size_t used = 0;
  ASSERT_EQ(p.feed(f.view(), &used), Parser::Event::kTelegram);
  StatusReply r;
  ASSERT_TRUE(decode_status(p.telegram(), &r));
  EXPECT_EQ(r.scan_angle, 180);
  EXPECT_EQ(r.resolution, 50);
  EXPECT_EQ(r.units, 1);
  EXPECT_EQ(r.operating_mode, 0x24);
  EXPECT_STREQ(r.version.data(), "V02.10 ");
}

}  // namespace
}  // namespace cairn::lms

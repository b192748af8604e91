// The MCAP writer and reader (tools/mcap): a round trip, the byte layout the specification
// fixes (checked by hand, independently of the reader), every truncation and every
// single-byte corruption rejected, and write failures reported, never silent.
#include <gtest/gtest.h>
#include <csignal>
#include <sys/resource.h>
#include <unistd.h>
#include <zlib.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "tools/mcap/mcap_format.hpp"
#include "tools/mcap/mcap_reader.hpp"
#include "tools/mcap/mcap_writer.hpp"

namespace cairn::mcap {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("cairn-mcap-test-" + std::to_string(getpid()));
  TempDir() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

std::vector<std::uint8_t> slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

std::uint64_t le(const std::vector<std::uint8_t>& b, std::size_t at, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(b.at(at + static_cast<std::size_t>(i))) << (8 * i);
  return v;
}

std::uint32_t zcrc(const std::vector<std::uint8_t>& b, std::size_t from, std::size_t to) {
  return static_cast<std::uint32_t>(crc32(0, b.data() + from, static_cast<uInt>(to - from)));
}

// Two schemas, two channels (one with metadata), three messages (one empty).
fs::path write_sample(const fs::path& dir) {
  const fs::path p = dir / "sample.mcap";
  Writer w(p.string(), "", "test-lib");
  const auto s1 = w.add_schema({"cairn::A", "omgidl", "module cairn { struct A { long x; }; };"});
  const auto s2 = w.add_schema({"cairn::B", "omgidl", "module cairn { struct B { double y; }; };"});
  const auto c0 = w.add_channel({s1, "topic_a", "cdr", {}});
  const auto c1 = w.add_channel({s2, "topic_b", "cdr", {{"k", "v"}, {"key2", "value2"}}});
  const std::uint8_t d0[] = {0, 1, 0, 0, 42, 0, 0, 0};
  w.add_message(c0, 1, 1000, 900, d0, sizeof d0);
  w.add_message(c1, 1, 2000, 1900, nullptr, 0);
  const std::uint8_t d2[] = {0, 1, 0, 0, 7, 7, 7, 7, 1, 2, 3, 4};
  w.add_message(c0, 2, 3000, 2900, d2, sizeof d2);
  w.close();
  return p;
}

TEST(Mcap, RoundTrip) {
  TempDir dir;
  const File f(write_sample(dir.path).string());
  const Contents& c = f.contents();
  EXPECT_EQ(c.library, "test-lib");
  ASSERT_EQ(c.schemas.size(), 2u);
  EXPECT_EQ(c.schemas.at(1).name, "cairn::A");
  EXPECT_EQ(c.schemas.at(2).data, "module cairn { struct B { double y; }; };");
  ASSERT_EQ(c.channels.size(), 2u);
  EXPECT_EQ(c.channels.at(0).topic, "topic_a");
  EXPECT_EQ(c.channels.at(1).schema_id, 2);
  EXPECT_EQ(c.channels.at(1).metadata, (std::map<std::string, std::string>{{"k", "v"}, {"key2", "value2"}}));
  ASSERT_EQ(c.messages.size(), 3u);
  EXPECT_EQ(c.messages[0].channel, 0);
  EXPECT_EQ(c.messages[0].log_time, 1000u);
  EXPECT_EQ(c.messages[0].publish_time, 900u);
  EXPECT_EQ(std::vector<std::uint8_t>(c.messages[0].data.begin(), c.messages[0].data.end()),
            (std::vector<std::uint8_t>{0, 1, 0, 0, 42, 0, 0, 0}));
  EXPECT_TRUE(c.messages[1].data.empty());
  EXPECT_EQ(c.messages[2].sequence, 2u);
  EXPECT_EQ(c.messages[2].data.size(), 12u);
  EXPECT_TRUE(c.has_statistics);
  EXPECT_EQ(c.statistics_messages, 3u);
}

// The layout read by hand from the specification: magic, Header, records framed by
// opcode + u64 length, DataEnd's CRC of everything before it, the Footer's offsets and
// the CRC from the summary start through the Footer's summary_offset_start.
TEST(Mcap, ByteLayoutFollowsTheSpecification) {
  TempDir dir;
  const auto b = slurp(write_sample(dir.path));
  ASSERT_GT(b.size(), 16u + 9 + kFooterContent);
  const std::vector<std::uint8_t> magic = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
  EXPECT_EQ(std::vector<std::uint8_t>(b.begin(), b.begin() + 8), magic);
  EXPECT_EQ(std::vector<std::uint8_t>(b.end() - 8, b.end()), magic);
  // Header: profile "" and library "test-lib".
  EXPECT_EQ(b[8], 0x01);
  EXPECT_EQ(le(b, 9, 8), 4u + 0 + 4 + 8);
  EXPECT_EQ(le(b, 17, 4), 0u);
  EXPECT_EQ(le(b, 21, 4), 8u);
  EXPECT_EQ(std::string(b.begin() + 25, b.begin() + 33), "test-lib");
  // First Schema: id 1, name, encoding, data.
  EXPECT_EQ(b[33], 0x03);
  EXPECT_EQ(le(b, 42, 2), 1u);
  EXPECT_EQ(le(b, 44, 4), 8u);
  EXPECT_EQ(std::string(b.begin() + 48, b.begin() + 56), "cairn::A");
  // Footer: 29 bytes before the closing magic.
  const std::size_t footer = b.size() - 8 - 9 - kFooterContent;
  EXPECT_EQ(b[footer], 0x02);
  EXPECT_EQ(le(b, footer + 1, 8), kFooterContent);
  const std::size_t summary_start = le(b, footer + 9, 8);
  EXPECT_EQ(le(b, footer + 17, 8), 0u);  // no summary offset section
  EXPECT_EQ(le(b, footer + 25, 4), zcrc(b, summary_start, footer + 25));
  // DataEnd just before the summary, whose first record is the first Schema again.
  const std::size_t data_end = summary_start - 9 - 4;
  EXPECT_EQ(b[data_end], 0x0F);
  EXPECT_EQ(le(b, data_end + 1, 8), 4u);
  EXPECT_EQ(le(b, data_end + 9, 4), zcrc(b, 0, data_end));
  EXPECT_EQ(b[summary_start], 0x03);
  // A Message: channel u16, sequence u32, log_time u64, publish_time u64, then the data.
  const std::size_t first_message = [&] {
    std::size_t at = 8;
    while (b.at(at) != 0x05) at += 9 + le(b, at + 1, 8);
    return at;
  }();
  EXPECT_EQ(le(b, first_message + 1, 8), 2u + 4 + 8 + 8 + 8);
  EXPECT_EQ(le(b, first_message + 9, 2), 0u);
  EXPECT_EQ(le(b, first_message + 11, 4), 1u);
  EXPECT_EQ(le(b, first_message + 15, 8), 1000u);
  EXPECT_EQ(le(b, first_message + 23, 8), 900u);
  EXPECT_EQ(b[first_message + 31 + 4], 42);
}

// tests/fuzz/corpus/mcap/two_messages.mcap was written from the specification by a separate
// (Python) encoder, not by this writer: the reader agrees with another reading of the spec.
TEST(Mcap, ReadsAFileWrittenByAnotherEncoder) {
  const File f(std::string(CAIRN_SOURCE_DIR_STR) + "/tests/fuzz/corpus/mcap/two_messages.mcap");
  const Contents& c = f.contents();
  EXPECT_EQ(c.library, "seed");
  ASSERT_EQ(c.channels.size(), 1u);
  EXPECT_EQ(c.channels.at(0).topic, "cairn_odometry");
  EXPECT_EQ(c.channels.at(0).metadata.at("k"), "v");
  ASSERT_EQ(c.messages.size(), 2u);
  EXPECT_EQ(c.messages[1].log_time, 2000u);
  EXPECT_EQ(c.messages[1].data[4], 1);
  EXPECT_EQ(c.statistics_messages, 2u);
  EXPECT_THROW(File(std::string(CAIRN_SOURCE_DIR_STR) + "/tests/fuzz/corpus/mcap/truncated.mcap"), FormatError);
}

TEST(Mcap, EveryTruncationIsRejected) {
  TempDir dir;
  const auto b = slurp(write_sample(dir.path));
  for (std::size_t n = 0; n < b.size(); ++n) {
    EXPECT_THROW(parse(std::span(b.data(), n)), FormatError) << "truncated to " << n << " bytes";
  }
  try {
    parse(std::span(b.data(), b.size() - 40));
    ADD_FAILURE() << "a truncated file was accepted";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
}

// The CRCs and the structure leave no byte unchecked: any single changed byte is caught.
TEST(Mcap, EverySingleByteCorruptionIsRejected) {
  TempDir dir;
  const auto good = slurp(write_sample(dir.path));
  ASSERT_NO_THROW(parse(good));
  for (std::size_t i = 0; i < good.size(); ++i) {
    auto b = good;
    b[i] ^= 0x5A;
    EXPECT_THROW(parse(b), FormatError) << "byte " << i << " changed";
  }
}

TEST(Mcap, StructuralErrorsAreNamed) {
  RecordEncoder e;
  e.bytes(kMagic.data(), kMagic.size());
  std::size_t r = e.begin_record(static_cast<std::uint8_t>(Op::kHeader));
  e.str("");
  e.str("x");
  e.end_record(r);
  r = e.begin_record(static_cast<std::uint8_t>(Op::kMessage));
  e.u16(7);  // no such channel
  e.u32(1);
  e.u64(1);
  e.u64(1);
  e.end_record(r);
  try {
    parse(e.buffer());
    ADD_FAILURE() << "a message on an unknown channel was accepted";
  } catch (const FormatError& err) {
    EXPECT_NE(std::string(err.what()).find("unknown channel 7"), std::string::npos) << err.what();
  }
  const std::vector<std::uint8_t> not_mcap = {'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r', 'l', 'd'};
  EXPECT_THROW(parse(not_mcap), FormatError);
}

TEST(Mcap, WriterNeverOverwritesUnlessAsked) {
  TempDir dir;
  const fs::path p = write_sample(dir.path);
  const auto before = slurp(p);
  EXPECT_THROW(Writer(p.string(), "", "x"), WriteError);
  EXPECT_EQ(slurp(p), before);
  Writer w(p.string(), "", "x", true);
  w.close();
  EXPECT_LT(slurp(p).size(), before.size());
}

TEST(Mcap, FullDiskIsAnError) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full here";
  try {
    Writer w("/dev/full", "", "x", true);  // the Header's write fails at once (ENOSPC)
    ADD_FAILURE() << "writing to /dev/full succeeded";
  } catch (const WriteError& e) {
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
  }
}

/// A file-size limit for this process (writes beyond it fail with EFBIG, SIGXFSZ ignored).
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    old_handler_ = std::signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &old_);
    rlimit l = old_;
    l.rlim_cur = bytes;
    ok_ = setrlimit(RLIMIT_FSIZE, &l) == 0;
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &old_);
    std::signal(SIGXFSZ, old_handler_);
  }
  bool ok() const { return ok_; }

 private:
  rlimit old_{};
  void (*old_handler_)(int) = nullptr;
  bool ok_ = false;
};

TEST(Mcap, FileSizeLimitMidRecordingIsAnErrorNamingTheFile) {
  TempDir dir;
  const fs::path p = dir.path / "limited.mcap";
  std::string what;
  std::uint64_t accepted = 0;
  {
    FileSizeLimit limit(64 * 1024);
    ASSERT_TRUE(limit.ok());
    try {
      Writer w(p.string(), "", "x");
      const auto ch = w.add_channel({0, "t", "cdr", {}});
      const std::vector<std::uint8_t> data(1000, 0xAB);
      for (int i = 0; i < 1000; ++i) {
        w.add_message(ch, static_cast<std::uint32_t>(i), static_cast<std::uint64_t>(i), 0, data.data(), data.size());
        ++accepted;
      }
      w.close();
    } catch (const WriteError& e) {
      what = e.what();
    }
  }
  EXPECT_NE(what.find("File too large"), std::string::npos) << what;
  EXPECT_NE(what.find(p.string()), std::string::npos) << what;
  EXPECT_LT(accepted, 1000u);
  // What was written is a prefix the reader refuses as truncated, not a silently short file.
  EXPECT_THROW(File(p.string()), FormatError);
}

}  // namespace
}  // namespace cairn::mcap

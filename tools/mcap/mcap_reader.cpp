#include "tools/mcap/mcap_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <string_view>

#include "tools/mcap/mcap_format.hpp"

namespace cairn::mcap {

namespace {

/// Bounds-checked little-endian reads over one record's content (or the whole file).
class Cursor {
 public:
  Cursor(std::span<const std::uint8_t> b, std::uint64_t base, const char* what) : b_(b), base_(base), what_(what) {}
  std::uint64_t uint(int n) {
    need(static_cast<std::size_t>(n));
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(b_[pos_ + static_cast<std::size_t>(i)]) << (8 * i);
    pos_ += static_cast<std::size_t>(n);
    return v;
  }
  std::uint8_t u8() { return static_cast<std::uint8_t>(uint(1)); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(uint(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(uint(4)); }
  std::uint64_t u64() { return uint(8); }
  std::span<const std::uint8_t> take(std::uint64_t n) {
    need(n);
    auto s = b_.subspan(pos_, static_cast<std::size_t>(n));
    pos_ += static_cast<std::size_t>(n);
    return s;
  }
  std::string str() {
    const auto s = take(u32());
    return std::string(s.begin(), s.end());
  }
  std::span<const std::uint8_t> rest() { return take(b_.size() - pos_); }
  std::size_t remaining() const { return b_.size() - pos_; }
  std::size_t pos() const { return pos_; }
  std::uint64_t offset() const { return base_ + pos_; }
  [[noreturn]] void fail(const std::string& why) const {
    throw FormatError("MCAP: " + why + " (" + what_ + " at byte " + std::to_string(offset()) + ")");
  }

 private:
  void need(std::uint64_t n) const {
    if (n > b_.size() - pos_) fail("needs " + std::to_string(n) + " bytes, " + std::to_string(b_.size() - pos_) + " left");
  }
  std::span<const std::uint8_t> b_;
  std::size_t pos_ = 0;
  std::uint64_t base_;
  std::string what_;
};

const char* op_name(std::uint8_t op) {
  switch (static_cast<Op>(op)) {
    case Op::kHeader: return "Header";
    case Op::kFooter: return "Footer";
    case Op::kSchema: return "Schema";
    case Op::kChannel: return "Channel";
    case Op::kMessage: return "Message";
    case Op::kChunk: return "Chunk";
    case Op::kDataEnd: return "DataEnd";
    case Op::kStatistics: return "Statistics";
    default: return "record";
  }
}

SchemaInfo read_schema(Cursor& c, std::uint16_t* id) {
  *id = c.u16();
  SchemaInfo s;
  s.name = c.str();
  s.encoding = c.str();
  s.data = c.str();
  return s;
}

ChannelInfo read_channel(Cursor& c, std::uint16_t* id) {
  *id = c.u16();
  ChannelInfo ch;
  ch.schema_id = c.u16();
  ch.topic = c.str();
  ch.message_encoding = c.str();
  const std::uint32_t map_bytes = c.u32();
  Cursor m(c.take(map_bytes), c.offset() - map_bytes, "Channel metadata");
  while (m.remaining() > 0) {
    std::string k = m.str();
    ch.metadata[std::move(k)] = m.str();
  }
  return ch;
}

}  // namespace

Contents parse(std::span<const std::uint8_t> bytes) {
  Contents out;
  Cursor file(bytes, 0, "file");
  if (bytes.size() < kMagic.size() || !std::equal(kMagic.begin(), kMagic.end(), bytes.begin()))
    file.fail("not an MCAP file (no leading magic)");
  file.take(kMagic.size());
  std::uint32_t data_crc = crc32_update(0, bytes.data(), kMagic.size());
  bool in_summary = false, seen_header = false;
  std::uint64_t summary_start = 0;
  for (;;) {
    if (file.remaining() == 0)
      file.fail(std::string("truncated: ") + (in_summary ? "summary" : "data section") + " ends after " +
                std::to_string(out.messages.size()) + " messages without a Footer (was the recorder stopped by force?)");
    const std::size_t record_at = file.pos();
    const std::uint8_t op = file.u8();
    const std::uint64_t len = file.u64();
    if (len > file.remaining()) file.fail(std::string("truncated ") + op_name(op) + ": content of " + std::to_string(len) + " bytes");
    Cursor c(file.take(len), file.offset() - len, op_name(op));
    if (!seen_header && op != static_cast<std::uint8_t>(Op::kHeader)) c.fail("the first record is not a Header");
    if (op == static_cast<std::uint8_t>(Op::kFooter)) {
      if (!in_summary) c.fail("Footer before DataEnd");
      const std::uint64_t start = c.u64();
      c.u64();  // summary offset section: not used
      const std::size_t crc_at = file.pos() - 4;
      const std::uint32_t crc = c.u32();
      if (start != 0 && start != summary_start) c.fail("Footer's summary_start does not match the summary");
      if (start != 0 && crc != 0 && crc != crc32_update(0, bytes.data() + start, crc_at - start)) c.fail("summary CRC mismatch");
      if (file.remaining() != kMagic.size() || !std::equal(kMagic.begin(), kMagic.end(), bytes.end() - 8))
        file.fail("no closing magic right after the Footer");
      if (out.has_statistics && out.statistics_messages != out.messages.size())
        c.fail("Statistics count " + std::to_string(out.statistics_messages) + " messages, the file holds " +
               std::to_string(out.messages.size()));
      return out;
    }
    if (!in_summary && op != static_cast<std::uint8_t>(Op::kDataEnd))
      data_crc = crc32_update(data_crc, bytes.data() + record_at, file.pos() - record_at);
    switch (static_cast<Op>(op)) {
      case Op::kHeader:
        if (seen_header) c.fail("a second Header");
        seen_header = true;
        out.profile = c.str();
        out.library = c.str();
        break;
      case Op::kSchema: {
        std::uint16_t id = 0;
        SchemaInfo s = read_schema(c, &id);
        if (id == 0) c.fail("schema id 0 is reserved");
        auto [it, fresh] = out.schemas.emplace(id, s);
        if (!fresh && (it->second.name != s.name || it->second.data != s.data)) c.fail("schema " + std::to_string(id) + " redefined");
        break;
      }
      case Op::kChannel: {
        std::uint16_t id = 0;
        ChannelInfo ch = read_channel(c, &id);
        if (ch.schema_id != 0 && !out.schemas.contains(ch.schema_id))
          c.fail("channel " + std::to_string(id) + " names unknown schema " + std::to_string(ch.schema_id));
        auto [it, fresh] = out.channels.emplace(id, ch);
        if (!fresh && it->second.topic != ch.topic) c.fail("channel " + std::to_string(id) + " redefined");
        break;
      }
      case Op::kMessage: {
        if (in_summary) c.fail("Message in the summary section");
        Message m;
        m.channel = c.u16();
        m.sequence = c.u32();
        m.log_time = c.u64();
        m.publish_time = c.u64();
        m.data = c.rest();
        if (!out.channels.contains(m.channel)) c.fail("message on unknown channel " + std::to_string(m.channel));
        out.messages.push_back(m);
        break;
      }
      case Op::kChunk: c.fail("chunked MCAP files are not supported by this reader");
      case Op::kDataEnd: {
        if (in_summary) c.fail("a second DataEnd");
        const std::uint32_t crc = c.u32();
        if (crc != 0 && crc != data_crc) c.fail("data section CRC mismatch");
        in_summary = true;
        summary_start = file.pos();
        break;
      }
      case Op::kStatistics:
        out.has_statistics = true;
        out.statistics_messages = c.u64();
        break;
      default: break;  // indexes, attachments, metadata: not needed to replay
    }
  }
}

File::File(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw FormatError(path + ": cannot open: " + std::strerror(errno));
  bytes_.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  if (f.bad()) throw FormatError(path + ": read failed");
  try {
    contents_ = parse(bytes_);
  } catch (const FormatError& e) {
    throw FormatError(path + ": " + e.what());
  }
}

}  // namespace cairn::mcap

#include "tools/mcap/mcap_writer.hpp"

#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "tools/mcap/mcap_format.hpp"

namespace cairn::mcap {

namespace {
constexpr std::size_t kFlushBytes = 256 * 1024;
}

std::uint32_t crc32_update(std::uint32_t crc, const void* p, std::size_t n) {
  const auto* b = static_cast<const Bytef*>(p);
  while (n > 0) {  // zlib takes uInt lengths
    const uInt step = static_cast<uInt>(std::min<std::size_t>(n, 1u << 30));
    crc = static_cast<std::uint32_t>(::crc32(crc, b, step));
    b += step;
    n -= step;
  }
  return crc;
}

void RecordEncoder::le(std::uint64_t v, int n) {
  for (int i = 0; i < n; ++i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

void RecordEncoder::str(std::string_view s) {
  u32(static_cast<std::uint32_t>(s.size()));
  bytes(s.data(), s.size());
}

void RecordEncoder::bytes(const void* p, std::size_t n) {
  const auto* b = static_cast<const std::uint8_t*>(p);
  out_.insert(out_.end(), b, b + n);
}

std::size_t RecordEncoder::begin_record(std::uint8_t op) {
  u8(op);
  const std::size_t start = out_.size();
  u64(0);
  return start;
}

void RecordEncoder::end_record(std::size_t start) {
  const std::uint64_t len = out_.size() - start - 8;
  for (int i = 0; i < 8; ++i) out_[start + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(len >> (8 * i));
}

Writer::Writer(const std::string& path, std::string_view profile, std::string_view library, bool overwrite)
    : path_(path) {
  // Never truncates a recording by accident.
  // 0600: a recording holds every topic in the clear, also a secure fleet's (docs/security.md).
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | (overwrite ? O_TRUNC : O_EXCL), 0600);
  if (fd_ < 0) throw WriteError(path + ": cannot create: " + std::strerror(errno));
  enc_.bytes(kMagic.data(), kMagic.size());
  const std::size_t h = enc_.begin_record(static_cast<std::uint8_t>(Op::kHeader));
  enc_.str(profile);
  enc_.str(library);
  enc_.end_record(h);
  emit(true);
}

Writer::~Writer() {
  if (fd_ >= 0) ::close(fd_);
}

namespace {
void encode_channel(RecordEncoder& e, std::uint16_t id, const ChannelInfo& c) {
  const std::size_t r = e.begin_record(static_cast<std::uint8_t>(Op::kChannel));
  e.u16(id);
  e.u16(c.schema_id);
  e.str(c.topic);
  e.str(c.message_encoding);
  std::uint32_t map_bytes = 0;
  for (const auto& [k, v] : c.metadata) map_bytes += static_cast<std::uint32_t>(8 + k.size() + v.size());
  e.u32(map_bytes);
  for (const auto& [k, v] : c.metadata) {
    e.str(k);
    e.str(v);
  }
  e.end_record(r);
}

void encode_schema(RecordEncoder& e, std::uint16_t id, const SchemaInfo& s) {
  const std::size_t r = e.begin_record(static_cast<std::uint8_t>(Op::kSchema));
  e.u16(id);
  e.str(s.name);
  e.str(s.encoding);
  e.str(s.data);
  e.end_record(r);
}
}  // namespace

std::uint16_t Writer::add_schema(const SchemaInfo& s) {
  const auto id = static_cast<std::uint16_t>(schemas_.size() + 1);  // 0 means "no schema"
  encode_schema(enc_, id, s);
  schemas_.emplace_back(id, s);
  emit(false);
  return id;
}

std::uint16_t Writer::add_channel(const ChannelInfo& c) {
  const auto id = static_cast<std::uint16_t>(channels_.size());
  encode_channel(enc_, id, c);
  channels_.emplace_back(id, c);
  emit(false);
  return id;
}

void Writer::add_message(std::uint16_t channel, std::uint32_t sequence, std::uint64_t log_time,
                         std::uint64_t publish_time, const void* data, std::size_t size) {
  const std::size_t r = enc_.begin_record(static_cast<std::uint8_t>(Op::kMessage));
  enc_.u16(channel);
  enc_.u32(sequence);
  enc_.u64(log_time);
  enc_.u64(publish_time);
  enc_.bytes(data, size);
  enc_.end_record(r);
  if (message_count_ == 0 || log_time < first_time_) first_time_ = log_time;
  if (message_count_ == 0 || log_time > last_time_) last_time_ = log_time;
  ++message_count_;
  ++per_channel_[channel];
  emit(false);
}

void Writer::flush() { emit(true); }

void Writer::emit(bool force) {
  auto& b = enc_.buffer();
  if (b.empty() || (!force && b.size() < kFlushBytes)) return;
  data_crc_ = crc32_update(data_crc_, b.data(), b.size());
  write_all(b.data(), b.size());
  b.clear();
}

void Writer::write_all(const std::uint8_t* p, std::size_t n) {
  if (fd_ < 0) throw WriteError(path_ + ": write after a failed write or close");
  while (n > 0) {
    const ssize_t w = ::write(fd_, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      const int e = w < 0 ? errno : ENOSPC;  // a 0-byte write: no progress, treated as a full disk
      ::close(fd_);
      fd_ = -1;
      throw WriteError(path_ + ": write failed at byte " + std::to_string(offset_) + ": " + std::strerror(e));
    }
    p += w;
    n -= static_cast<std::size_t>(w);
    offset_ += static_cast<std::uint64_t>(w);
  }
}

void Writer::close() {
  if (closed_) return;
  emit(true);  // data_crc_ now covers the whole data section
  RecordEncoder tail;
  std::size_t r = tail.begin_record(static_cast<std::uint8_t>(Op::kDataEnd));
  tail.u32(data_crc_);
  tail.end_record(r);
  const std::uint64_t summary_start = offset_ + tail.buffer().size();
  const std::size_t summary_at = tail.buffer().size();
  for (const auto& [id, s] : schemas_) encode_schema(tail, id, s);
  for (const auto& [id, c] : channels_) encode_channel(tail, id, c);
  r = tail.begin_record(static_cast<std::uint8_t>(Op::kStatistics));
  tail.u64(message_count_);
  tail.u16(static_cast<std::uint16_t>(schemas_.size()));
  tail.u32(static_cast<std::uint32_t>(channels_.size()));
  tail.u32(0);  // attachments
  tail.u32(0);  // metadata
  tail.u32(0);  // chunks
  tail.u64(first_time_);
  tail.u64(last_time_);
  tail.u32(static_cast<std::uint32_t>(per_channel_.size() * 10));
  for (const auto& [id, n] : per_channel_) {
    tail.u16(id);
    tail.u64(n);
  }
  tail.end_record(r);
  tail.u8(static_cast<std::uint8_t>(Op::kFooter));
  tail.u64(kFooterContent);  // the length is known: it must be in place before the CRC is taken
  tail.u64(summary_start);
  tail.u64(0);  // no summary offset section
  // The summary CRC covers the summary and the Footer up to (not including) the CRC itself.
  const auto& tb = tail.buffer();
  const std::uint32_t summary_crc = crc32_update(0, tb.data() + summary_at, tb.size() - summary_at);
  tail.u32(summary_crc);
  tail.bytes(kMagic.data(), kMagic.size());
  write_all(tail.buffer().data(), tail.buffer().size());
  if (::fsync(fd_) != 0 && errno != EINVAL) {
    const int e = errno;
    throw WriteError(path_ + ": fsync failed: " + std::strerror(e));
  }
  if (::close(fd_) != 0) {
    fd_ = -1;
    throw WriteError(path_ + ": close failed: " + std::strerror(errno));
  }
  fd_ = -1;
  closed_ = true;
}

}  // namespace cairn::mcap

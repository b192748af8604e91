// A small MCAP writer: Header, Schema, Channel and Message records in an unchunked data
// section, then DataEnd (with the data section's CRC), a summary (schemas, channels,
// Statistics), the Footer (with the summary's CRC) and the closing magic.
//
// Every write is checked: a full disk or a file-size limit throws WriteError naming the
// file and the reason, so a recorder can never lose data silently.
#pragma once

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace cairn::mcap {

class WriteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SchemaInfo {
  std::string name;      // e.g. "cairn::RobotStatus"
  std::string encoding;  // e.g. "omgidl"
  std::string data;      // e.g. the IDL text
};

struct ChannelInfo {
  std::uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;  // e.g. "cdr"
  std::map<std::string, std::string> metadata;
};

/// Appends MCAP records to a byte buffer (no I/O: the unit tests check its bytes).
class RecordEncoder {
 public:
  void u8(std::uint8_t v) { out_.push_back(v); }
  void u16(std::uint16_t v) { le(v, 2); }
  void u32(std::uint32_t v) { le(v, 4); }
  void u64(std::uint64_t v) { le(v, 8); }
  void str(std::string_view s);  // u32 length + bytes
  void bytes(const void* p, std::size_t n);
  std::vector<std::uint8_t>& buffer() { return out_; }

  /// Starts a record (opcode + a length placeholder); end_record() fills the length.
  std::size_t begin_record(std::uint8_t op);
  void end_record(std::size_t start);

 private:
  void le(std::uint64_t v, int n);
  std::vector<std::uint8_t> out_;
};

class Writer {
 public:
  /// Creates path (an existing file only if overwrite) and writes the magic and the Header.
  /// Throws WriteError.
  Writer(const std::string& path, std::string_view profile, std::string_view library, bool overwrite = false);
  ~Writer();  // closes without the summary if close() was not called (the file is then truncated)
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  std::uint16_t add_schema(const SchemaInfo& s);        // ids from 1
  std::uint16_t add_channel(const ChannelInfo& c);      // ids from 0
  /// log_time and publish_time in ns. Buffered; flushed every 256 KiB and by flush()/close().
  void add_message(std::uint16_t channel, std::uint32_t sequence, std::uint64_t log_time, std::uint64_t publish_time,
                   const void* data, std::size_t size);
  void flush();
  /// Writes DataEnd, the summary, the Footer and the magic; syncs the file. Throws WriteError.
  void close();

  std::uint64_t messages() const { return message_count_; }
  std::uint64_t bytes_written() const { return offset_; }
  const std::string& path() const { return path_; }

 private:
  void emit(bool force);  // writes the buffered bytes (all if force, else once 256 KiB gathered)
  void write_all(const std::uint8_t* p, std::size_t n);

  std::string path_;
  int fd_ = -1;
  RecordEncoder enc_;
  std::uint64_t offset_ = 0;      // bytes already written to the file
  std::uint32_t data_crc_ = 0;    // running CRC of everything written before DataEnd
  std::vector<std::pair<std::uint16_t, SchemaInfo>> schemas_;
  std::vector<std::pair<std::uint16_t, ChannelInfo>> channels_;
  std::map<std::uint16_t, std::uint64_t> per_channel_;
  std::uint64_t message_count_ = 0;
  std::uint64_t first_time_ = 0, last_time_ = 0;
  bool closed_ = false;
};

/// CRC-32 (zlib's), continued from crc.
std::uint32_t crc32_update(std::uint32_t crc, const void* p, std::size_t n);

}  // namespace cairn::mcap

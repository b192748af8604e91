// A small MCAP reader for what mcap_writer writes (and any unchunked MCAP file): it checks
// the magic at both ends, every record's length against the bytes present, the CRCs of the
// data section and the summary, and that every message names a known channel. A corrupt
// or truncated file gives FormatError with the byte offset and the reason, never a crash.
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "tools/mcap/mcap_writer.hpp"

namespace cairn::mcap {

class FormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Message {
  std::uint16_t channel = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;
  std::uint64_t publish_time = 0;
  std::span<const std::uint8_t> data;  // into the parsed bytes
};

struct Contents {
  std::string profile, library;
  std::map<std::uint16_t, SchemaInfo> schemas;
  std::map<std::uint16_t, ChannelInfo> channels;
  std::vector<Message> messages;  // in file order
  bool has_statistics = false;
  std::uint64_t statistics_messages = 0;  // the Statistics record's message_count (checked against messages)
};

/// Parses a whole file image; messages point into `bytes`, which must outlive the result.
Contents parse(std::span<const std::uint8_t> bytes);

/// A file read into memory and parsed. Throws FormatError (also for I/O errors).
class File {
 public:
  explicit File(const std::string& path);
  const Contents& contents() const { return contents_; }

 private:
  std::vector<std::uint8_t> bytes_;
  Contents contents_;
};

}  // namespace cairn::mcap

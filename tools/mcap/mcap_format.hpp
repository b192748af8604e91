// The parts of the MCAP container format (https://mcap.dev/spec, major version 0) that
// Cairn writes and reads: record opcodes and the magic. Little-endian throughout.
#pragma once

#include <array>
#include <cstdint>

namespace cairn::mcap {

inline constexpr std::array<std::uint8_t, 8> kMagic = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum class Op : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

/// Bytes of a record's frame: opcode (1) + content length (8).
inline constexpr std::size_t kRecordFrame = 9;
/// The Footer's content: summary_start, summary_offset_start (u64 each), summary_crc (u32).
inline constexpr std::size_t kFooterContent = 20;

}  // namespace cairn::mcap

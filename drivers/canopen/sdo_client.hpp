// SDO client for one node: expedited and segmented upload/download with a per-node
// timeout and retries, aborts decoded to text. A pure state machine: poll(now) says what
// to send, on_frame() takes the node's 0x580+n responses. Fixed buffer (no heap).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>

#include "drivers/canopen/canopen_codec.hpp"

namespace cairn::canopen {

class SdoClient {
 public:
  static constexpr std::size_t kMaxData = 256;
  enum class Status : std::uint8_t { kIdle, kBusy, kDone, kFailed };

  SdoClient(std::uint8_t node, Nanos timeout, int retries) : node_(node), timeout_(timeout), retries_(retries) {}

  /// Writes `data` (expedited up to 4 bytes, segmented above). False if busy or too long.
  bool download(SdoAddress a, std::span<const std::uint8_t> data);
  bool download_u32(SdoAddress a, std::uint32_t v, std::size_t bytes = 4);
  /// Reads an object (expedited or segmented).
  bool upload(SdoAddress a);

  /// The next frame to send, if any (first request, next segment, a retry after a timeout,
  /// or the abort of a transfer this client failed: toggle error, overrun, timeout).
  std::optional<Frame> poll(Nanos now);
  /// A frame from the bus; ignored unless it is this node's SDO response.
  void on_frame(const Frame& f, Nanos now);

  Status status() const { return status_; }
  /// After kDone of an upload: the bytes read.
  std::span<const std::uint8_t> data() const { return {buf_.data(), size_}; }
  std::uint32_t value() const;  // little-endian value of the first up-to-4 bytes
  /// After kFailed: the abort code (abort_code::kTimeout for our own timeout) and its text.
  std::uint32_t abort_code() const { return abort_; }
  const char* error() const { return sdo_abort_text(abort_); }
  std::uint64_t timeouts() const { return timeouts_count_; }
  void reset() { status_ = Status::kIdle; }

 private:
  enum class Op : std::uint8_t { kNone, kDownloadExpedited, kDownloadSegmented, kUpload };
  void fail(std::uint32_t code) {
    status_ = Status::kFailed;
    abort_ = code;
    pending_.reset();
  }
  /// Fails and tells the server: the abort goes out at the next poll().
  void fail_and_abort(std::uint32_t code);
  void send_next(Nanos now);

  std::uint8_t node_;
  Nanos timeout_;
  int retries_;
  Status status_ = Status::kIdle;
  Op op_ = Op::kNone;
  SdoAddress addr_;
  std::array<std::uint8_t, kMaxData> buf_{};
  std::size_t size_ = 0, offset_ = 0;
  bool toggle_ = false;
  bool initiated_ = false;
  std::optional<Frame> pending_;  // frame to hand out at the next poll
  std::optional<Frame> abort_out_;  // an abort owed to the server: sent at the next poll, even after kFailed
  Frame last_sent_;
  Nanos deadline_ = 0;
  int attempts_ = 0;
  std::uint32_t abort_ = 0;
  std::uint64_t timeouts_count_ = 0;
};

}  // namespace cairn::canopen

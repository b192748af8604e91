#include "drivers/canopen/sdo_client.hpp"

#include <algorithm>

namespace cairn::canopen {

namespace {
constexpr std::uint32_t kAbortTimeout = abort_code::kTimeout, kAbortToggle = abort_code::kToggleBit,
                        kAbortInvalid = abort_code::kCommand, kAbortTooLong = abort_code::kDataTooLong;
}

bool SdoClient::download(SdoAddress a, std::span<const std::uint8_t> data) {
  if (status_ == Status::kBusy || data.empty() || data.size() > kMaxData) return false;
  addr_ = a;
  std::copy(data.begin(), data.end(), buf_.begin());
  size_ = data.size();
  offset_ = 0;
  toggle_ = false;
  initiated_ = false;
  attempts_ = 0;
  status_ = Status::kBusy;
  if (size_ <= 4) {
    op_ = Op::kDownloadExpedited;
    pending_ = sdo_download(node_, a, {buf_.data(), size_});
  } else {
    op_ = Op::kDownloadSegmented;
    pending_ = sdo_download_initiate(node_, a, static_cast<std::uint32_t>(size_));
  }
  return true;
}

bool SdoClient::download_u32(SdoAddress a, std::uint32_t v, std::size_t bytes) {
  std::uint8_t b[4];
  for (int i = 0; i < 4; ++i) b[i] = static_cast<std::uint8_t>(v >> (8 * i));
  return download(a, {b, std::min<std::size_t>(bytes, 4)});
}

bool SdoClient::upload(SdoAddress a) {
  if (status_ == Status::kBusy) return false;
  addr_ = a;
  size_ = 0;
  offset_ = 0;
  toggle_ = false;
  initiated_ = false;
  attempts_ = 0;
  op_ = Op::kUpload;
  status_ = Status::kBusy;
  pending_ = sdo_upload(node_, a);
  return true;
}

std::uint32_t SdoClient::value() const {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < std::min<std::size_t>(size_, 4); ++i) v |= static_cast<std::uint32_t>(buf_[i]) << (8 * i);
  return v;
}

void SdoClient::fail_and_abort(std::uint32_t code) {
  fail(code);
  abort_out_ = sdo_abort(kCobSdoRx + node_, addr_, code);
}

std::optional<Frame> SdoClient::poll(Nanos now) {
  if (abort_out_) {
    const Frame f = *abort_out_;
    abort_out_.reset();
    return f;
  }
  if (status_ != Status::kBusy) return std::nullopt;
  if (pending_) {
    last_sent_ = *pending_;
    pending_.reset();
    deadline_ = now + timeout_;
    return last_sent_;
  }
  if (now > deadline_) {
    ++timeouts_count_;
    // Only an initiate is safe to repeat; mid-transfer the server's toggle state is unknown.
    if (++attempts_ <= retries_ && !initiated_) {
      deadline_ = now + timeout_;
      return last_sent_;
    }
    fail(kAbortTimeout);
    return sdo_abort(kCobSdoRx + node_, addr_, kAbortTimeout);
  }
  return std::nullopt;
}

void SdoClient::send_next(Nanos now) {
  (void)now;
  if (op_ == Op::kDownloadSegmented) {
    const std::size_t n = std::min<std::size_t>(7, size_ - offset_);
    const bool last = offset_ + n >= size_;
    pending_ = sdo_download_segment(node_, toggle_, {buf_.data() + offset_, n}, last);
    offset_ += n;
  } else {
    pending_ = sdo_upload_segment(node_, toggle_);
  }
}

void SdoClient::on_frame(const Frame& f, Nanos now) {
  if (status_ != Status::kBusy || !is_standard_data_frame(f) || f.id != kCobSdoTx + node_) return;
  const SdoResponse r = decode_sdo_response(f);
  if (r.type == SdoResponse::Type::kAbort) {
    fail(r.abort_code);
    return;
  }
  switch (op_) {
    case Op::kDownloadExpedited:
      if (r.type == SdoResponse::Type::kDownloadAck) status_ = Status::kDone;
      return;
    case Op::kDownloadSegmented:
      if (!initiated_ && r.type == SdoResponse::Type::kDownloadAck) {
        initiated_ = true;
        send_next(now);
      } else if (initiated_ && r.type == SdoResponse::Type::kDownloadSegmentAck) {
        if (r.toggle != toggle_) {
          fail_and_abort(kAbortToggle);
          return;
        }
        toggle_ = !toggle_;
        if (offset_ >= size_) {
          status_ = Status::kDone;
        } else {
          send_next(now);
        }
      }
      return;
    case Op::kUpload:
      if (!initiated_ && r.type == SdoResponse::Type::kUploadExpedited) {
        for (std::size_t i = 0; i < r.size; ++i) buf_[i] = static_cast<std::uint8_t>(r.value >> (8 * i));
        size_ = r.size;
        status_ = Status::kDone;
      } else if (!initiated_ && r.type == SdoResponse::Type::kUploadSegmentedInit) {
        initiated_ = true;
        send_next(now);
      } else if (initiated_ && r.type == SdoResponse::Type::kUploadSegment) {
        if (r.toggle != toggle_) {
          fail_and_abort(kAbortToggle);
          return;
        }
        if (size_ + r.size > kMaxData) {
          fail_and_abort(kAbortTooLong);
          return;
        }
        std::copy_n(r.segment.begin(), r.size, buf_.begin() + static_cast<long>(size_));
        size_ += r.size;
        toggle_ = !toggle_;
        if (r.last) {
          status_ = Status::kDone;
        } else {
          send_next(now);
        }
      } else if (r.type == SdoResponse::Type::kInvalid) {
        fail_and_abort(kAbortInvalid);
      }
      return;
    case Op::kNone:
      return;
  }
}

}  // namespace cairn::canopen

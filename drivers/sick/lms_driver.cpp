#include "drivers/sick/lms_driver.hpp"

#include <cstdarg>
#include <cstdio>
#include <numbers>

namespace cairn::lms {

const char* state_name(DriverState s) {
  switch (s) {
    case DriverState::kSearching: return "searching";
    case DriverState::kConfiguring: return "configuring";
    case DriverState::kStreaming: return "streaming";
    case DriverState::kError: return "error";
  }
  return "?";
}

LmsDriver::LmsDriver(serial::ByteStream* stream, Clock* clock, const LmsDriverConfig& cfg, ScanSink* sink)
    : stream_(stream), clock_(clock), cfg_(cfg), sink_(sink) {
  std::snprintf(link_name_.data(), link_name_.size(), "%s", stream_->describe().c_str());
  std::size_t n = 0;
  auto add = [&](std::uint32_t b) {
    for (std::size_t i = 0; i < n; ++i) {
      if (probe_order_[i] == b) return;
    }
    if (n < probe_order_.size()) probe_order_[n++] = b;
  };
  if (!stream_->can_set_baud()) {
    add(stream_->baud());
  } else {
    add(cfg_.target_baud);
    for (std::uint32_t b : kBauds) add(b);
  }
  for (std::size_t i = n; i < probe_order_.size(); ++i) probe_order_[i] = 0;
  start_search();
}

const LmsCounters& LmsDriver::counters() const {
  counters_.crc_errors = parser_.counters().crc_errors;
  counters_.resyncs = parser_.counters().resyncs;
  return counters_;
}

void LmsDriver::enter(DriverState s, const char* fmt, ...) {
  state_ = s;
  va_list ap;
  va_start(ap, fmt);
  std::vsnprintf(reason_.data(), reason_.size(), fmt, ap);
  va_end(ap);
}

void LmsDriver::send(const Frame& f, std::uint8_t expect, Nanos timeout) {
  last_request_ = f;
  expect_ = expect;
  last_timeout_value_ = timeout;
  deadline_ = clock_->now() + timeout + static_cast<Nanos>(static_cast<double>(f.size) * serial::byte_time_s(stream_->baud()) * 1e9);
  const serial::IoResult r = stream_->write(f.view(), cfg_.reply_timeout);
  if (r.status == serial::IoResult::Status::kClosed || r.status == serial::IoResult::Status::kError) {
    handle_io_failure(r, clock_->now());
  }
}

void LmsDriver::start_search() {
  enter(DriverState::kSearching, "probing baud rates");
  probe_index_ = 0;
  attempts_ = 0;
  probe_next();
}

void LmsDriver::probe_next() {
  if (probe_index_ >= probe_order_.size() || probe_order_[probe_index_] == 0) probe_index_ = 0;
  const std::uint32_t b = probe_order_[probe_index_++];
  if (const IoError e = stream_->baud() != b ? stream_->set_baud(b) : IoError{}; !e.ok()) {
    enter(DriverState::kError, "cannot set %u baud: %s (%s)", b, io_errc_text(e.code), e.sys_text());
    reopen_at_ = clock_->now() + cfg_.reopen_backoff;
    return;
  }
  parser_.reset();
  stream_->flush_input();
  enter(DriverState::kSearching, "probing at %u baud", b);
  // "Stop streaming" is answered at any time and quiets a device that was streaming.
  send(request_mode(kModeOnRequest), 0, cfg_.probe_timeout);
}

void LmsDriver::begin_step(Step s) {
  step_ = s;
  attempts_ = 0;
  switch (s) {
    case Step::kStop:
      send(request_mode(kModeOnRequest), kReplyMode, cfg_.mode_timeout);
      return;
    case Step::kBaud:
      if (stream_->baud() == cfg_.target_baud || !stream_->can_set_baud() || !baud_code(cfg_.target_baud)) {
        begin_step(Step::kType);
        return;
      }
      send(request_mode(*baud_code(cfg_.target_baud)), kReplyMode, cfg_.mode_timeout);
      return;
    case Step::kVerify:
      send(request_status(), kReplyStatus, cfg_.reply_timeout);
      return;
    case Step::kType:
      send(request_type(), kReplyType, cfg_.reply_timeout);
      return;
    case Step::kInstall:
      send(request_installation_mode({cfg_.password.data(), 8}), kReplyMode, cfg_.mode_timeout);
      return;
    case Step::kConfig: {
      ConfigBlock c = ConfigBlock::millimetres();
      c.bytes[5] = measuring_mode_;  // 32 m range, reflector bit above the 15-bit range field
      send(request_write_config(c.bytes), kReplyWriteConfig, cfg_.mode_timeout);
      return;
    }
    case Step::kVariant:
      send(request_variant(cfg_.angle_deg, cfg_.resolution_centideg), kReplyVariant, cfg_.reply_timeout);
      return;
    case Step::kLeave:
      send(request_mode(kModeOnRequest), kReplyMode, cfg_.mode_timeout);
      return;
    case Step::kStart:
      send(request_mode(kModeStreamAll), kReplyMode, cfg_.mode_timeout);
      return;
    case Step::kDone:
      return;
  }
}

void LmsDriver::on_reply(const Telegram& t) {
  if (t.command == kReplyNack) {
    enter(DriverState::kConfiguring, "request 0x%02X refused (0x92)", last_request_.bytes[4]);
    on_timeout(deadline_);  // retry now
    return;
  }
  if (t.command != expect_) return;
  const std::uint8_t first = t.data.empty() ? 0xFF : t.data[0];
  switch (step_) {
    case Step::kStop:
      begin_step(Step::kBaud);
      return;
    case Step::kBaud: {
      if (first != 0x00 || !stream_->set_baud(cfg_.target_baud).ok()) {
        enter(DriverState::kConfiguring, "baud change to %u refused; staying at %u", cfg_.target_baud, stream_->baud());
        begin_step(Step::kType);
        return;
      }
      expect_ = 0;
      deadline_ = 0;
      settle_until_ = clock_->now() + cfg_.baud_settle;
      return;
    }
    case Step::kVerify:
      begin_step(Step::kType);
      return;
    case Step::kType: {
      const std::size_t n = std::min(t.data.size() > 0 ? t.data.size() - 1 : 0, type_.size() - 1);
      for (std::size_t i = 0; i < n; ++i) type_[i] = static_cast<char>(t.data[i]);
      type_[n] = '\0';
      begin_step(Step::kInstall);
      return;
    }
    case Step::kInstall:
      if (first != 0x00) {
        enter(DriverState::kError, "installation mode refused (wrong password?)");
        reopen_at_ = clock_->now() + cfg_.reopen_backoff;
        return;
      }
      begin_step(Step::kConfig);
      return;
    case Step::kConfig:
      if (first != 0x01) {
        enter(DriverState::kError, "configuration (mm units, 32 m mode) refused");
        reopen_at_ = clock_->now() + cfg_.reopen_backoff;
        return;
      }
      begin_step(Step::kVariant);
      return;
    case Step::kVariant: {
      VariantReply v;
      if (!decode_variant(t, &v) || !v.accepted) {
        enter(DriverState::kError, "variant %u deg / %.2f deg refused", cfg_.angle_deg, cfg_.resolution_centideg / 100.0);
        reopen_at_ = clock_->now() + cfg_.reopen_backoff;
        return;
      }
      begin_step(Step::kLeave);
      return;
    }
    case Step::kLeave:
      begin_step(Step::kStart);
      return;
    case Step::kStart:
      if (first != 0x00) {
        on_timeout(deadline_);
        return;
      }
      step_ = Step::kDone;
      expect_ = 0;
      deadline_ = 0;
      last_scan_ = clock_->now();
      enter(DriverState::kStreaming, "streaming at %u baud, %u deg / %.2f deg", stream_->baud(), cfg_.angle_deg,
            cfg_.resolution_centideg / 100.0);
      return;
    case Step::kDone:
      return;
  }
}

void LmsDriver::on_timeout(Nanos now) {
  (void)now;
  if (state_ == DriverState::kSearching) {
    probe_next();
    return;
  }
  if (state_ != DriverState::kConfiguring) return;
  ++counters_.timeouts;
  if (++attempts_ < cfg_.retries) {
    parser_.reset();
    const Frame again = last_request_;
    const int keep = attempts_;
    send(again, expect_, last_timeout_value_);
    attempts_ = keep;
    return;
  }
  enter(DriverState::kSearching, "no reply to 0x%02X at %u baud", last_request_.bytes[4], stream_->baud());
  probe_index_ = 0;
  probe_next();
}

void LmsDriver::handle_io_failure(const serial::IoResult& r, Nanos now) {
  ++counters_.io_errors;
  enter(DriverState::kError, "%s: link %s (errno %d)", link_name_.data(),
        r.status == serial::IoResult::Status::kClosed ? "closed" : "failed", r.error);
  reopen_at_ = now + cfg_.reopen_backoff;
}

void LmsDriver::emit_scan(const Telegram& t, Nanos end_time) {
  if (!decode_values(t, measuring_mode_, &values_)) {
    ++counters_.bad_scans;
    return;
  }
  const int bits = range_bits(measuring_mode_);
  const std::uint32_t scale = values_.units == Units::kMillimetres ? 1 : (values_.units == Units::kCentimetres ? 10 : 100);
  const std::uint32_t no_echo = ((bits >= 16 ? 0xFFFFu : (1u << bits) - 1u)) * scale;
  scan_.seq = ++seq_;
  scan_.count = values_.count;
  const double res_deg = values_.count > 1 ? static_cast<double>(cfg_.angle_deg) / (values_.count - 1) : 1.0;
  // An interlaced partial scan (index 1..3) starts index x 0.25 deg further round.
  scan_.angle_min = (-static_cast<double>(cfg_.angle_deg) / 2.0 + 0.25 * values_.partial_index) * std::numbers::pi / 180.0;
  scan_.angle_increment = res_deg * std::numbers::pi / 180.0;
  scan_.beam_period_s = res_deg / 360.0 / 75.0;
  for (std::uint16_t i = 0; i < values_.count; ++i) {
    scan_.range_mm[i] = values_.range_mm[i] >= no_echo ? 0 : values_.range_mm[i];
    scan_.flags[i] = values_.flags[i];
  }
  const std::size_t telegram_bytes = static_cast<std::size_t>(t.length) + 6;
  scan_.first_byte_time = serial::first_byte_time(end_time, telegram_bytes, stream_->baud());
  const Nanos latency = cfg_.scan_latency >= 0 ? cfg_.scan_latency
                                                : static_cast<Nanos>(cfg_.angle_deg / 360.0 / 75.0 * 1e9);
  scan_.stamp = scan_.first_byte_time - latency;
  ++counters_.scans;
  last_scan_ = clock_->now();
  if (sink_) sink_->on_scan(scan_);
}

void LmsDriver::on_telegram(const Telegram& t, Nanos read_time, std::size_t bytes_after) {
  if (t.command == kReplyPowerOn) {
    ++counters_.power_on_telegrams;
    if (state_ != DriverState::kSearching) {
      ++counters_.reconnects;
      enter(DriverState::kSearching, "device powered on again");
    }
    parser_.reset();
    begin_step(Step::kStop);
    state_ = DriverState::kConfiguring;
    return;
  }
  switch (state_) {
    case DriverState::kSearching:
      enter(DriverState::kConfiguring, "found at %u baud", stream_->baud());
      begin_step(Step::kStop);
      return;
    case DriverState::kConfiguring:
      on_reply(t);
      return;
    case DriverState::kStreaming:
      if (t.command == kReplyValues) {
        // The telegram's last byte arrived before the bytes that followed it in this read.
        const Nanos end = read_time - static_cast<Nanos>(static_cast<double>(bytes_after) * serial::byte_time_s(stream_->baud()) * 1e9);
        emit_scan(t, end);
      }
      return;
    case DriverState::kError:
      return;
  }
}

void LmsDriver::step() {
  Nanos now = clock_->now();
  if (state_ == DriverState::kError) {
    if (now < reopen_at_) {
      clock_->sleep_until(std::min(reopen_at_, now + cfg_.io_slice));
      return;
    }
    if (const IoError e = stream_->reopen(); e.ok()) {
      ++counters_.reconnects;
      start_search();
    } else if (e.code == IoErrc::kConnecting) {
      // A connect under way (tcp:): look again after one slice, not a whole backoff.
      enter(DriverState::kError, "%s: %s", link_name_.data(), io_errc_text(e.code));
      reopen_at_ = now + cfg_.io_slice;
    } else {
      enter(DriverState::kError, "%s: reopen failed: %s (%s)", link_name_.data(), io_errc_text(e.code), e.sys_text());
      reopen_at_ = now + cfg_.reopen_backoff;
    }
    return;
  }
  if (settle_until_ > 0) {
    if (now < settle_until_) {
      clock_->sleep_until(std::min(settle_until_, now + cfg_.io_slice));
      return;
    }
    settle_until_ = 0;
    parser_.reset();
    stream_->flush_input();
    begin_step(Step::kVerify);
    return;
  }
  const serial::IoResult r = stream_->read(rx_, cfg_.io_slice);
  const Nanos read_time = clock_->now();
  if (r.status == serial::IoResult::Status::kClosed || r.status == serial::IoResult::Status::kError) {
    handle_io_failure(r, read_time);
    return;
  }
  std::span<const std::uint8_t> rest(rx_.data(), r.bytes);
  while (!rest.empty()) {
    std::size_t used = 0;
    const Parser::Event ev = parser_.feed(rest, &used);
    rest = rest.subspan(used);
    if (ev == Parser::Event::kTelegram) {
      on_telegram(parser_.telegram(), read_time, rest.size());
      if (state_ == DriverState::kError || settle_until_ > 0) return;
    } else if (ev == Parser::Event::kNakByte) {
      ++counters_.naks;
    }
  }
  now = clock_->now();
  if (state_ == DriverState::kStreaming) {
    // Silence is judged against the line: at 9600 baud one 361-beam telegram takes 0.76 s.
    const double beams = cfg_.angle_deg * 100.0 / cfg_.resolution_centideg + 1.0;
    const Nanos line = static_cast<Nanos>((2.0 * beams + 10.0) * serial::byte_time_s(stream_->baud()) * 1e9);
    if (now - last_scan_ > cfg_.stream_timeout + 2 * line) {
      ++counters_.timeouts;
      ++counters_.reconnects;
      enter(DriverState::kSearching, "no scan for %lld ms", static_cast<long long>((now - last_scan_) / kNanosPerMilli));
      probe_index_ = 0;
      probe_next();
    }
    return;
  }
  if (deadline_ > 0 && now > deadline_) on_timeout(now);
}

}  // namespace cairn::lms

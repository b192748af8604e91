#include "hil/lms2xx/sim_lms_link.hpp"

#include <algorithm>
#include <vector>

namespace cairn::hil {

namespace {
constexpr Nanos kIdleTick = 100 * kNanosPerMicro;  // how often an idle device is polled
}

SimLmsLink::SimLmsLink(LmsDeviceConfig cfg, const World* world, LmsDevice::PoseSource pose, Nanos start)
    : clock_(this, start), device_(std::move(cfg), world, std::move(pose)) {
  device_.power_on(start);
  line_free_at_ = start;
}

Nanos SimLmsLink::byte_time() const {
  return static_cast<Nanos>(serial::byte_time_s(device_.baud()) * 1e9);
}

void SimLmsLink::power_cycle() {
  device_.power_on(clock_.now());
  busy_ = false;
}

void SimLmsLink::advance_to(Nanos t) {
  while (clock_.now_ < t) {
    // Step to the end of the byte on the line, or by the idle tick.
    const Nanos next = busy_ ? std::max(line_free_at_ + byte_time(), clock_.now_ + 1) : clock_.now_ + kIdleTick;
    step_to(std::min(t, next));
  }
}

void SimLmsLink::step_to(Nanos t) {
  const Nanos now = clock_.now_;
  device_.poll(now, device_.tx().empty());
  if (device_.tx().empty()) {
    if (busy_) {
      device_.on_tx_drained(now);
      busy_ = false;
    }
    line_free_at_ = now;
  } else if (!busy_) {
    busy_ = true;
    line_free_at_ = now;  // the first byte starts now
  }
  const Nanos bt = byte_time();
  auto& sent = device_.sent_scans();
  while (!device_.tx().empty() && line_free_at_ + bt <= t) {
    const std::uint64_t index = device_.popped();
    const Nanos start = line_free_at_;
    for (auto it = sent.rbegin(); it != sent.rend() && it->first_byte + it->bytes > index; ++it) {
      if (it->first_byte == index) it->tx_start = start;
      if (it->first_byte + it->bytes == index + 1) it->last_byte_written = start + bt;
    }
    const std::uint8_t b = device_.pop_tx();
    line_free_at_ = start + bt;
    if (unplugged_) continue;  // the bytes go nowhere
    // At a rate the host is not listening at, the host sees framing garbage.
    rx_.push_back(host_baud_ == device_.baud() ? b : static_cast<std::uint8_t>(noise_()));
  }
  clock_.now_ = t;
}

serial::IoResult SimLmsLink::read(std::span<std::uint8_t> buffer, Nanos timeout) {
  const Nanos deadline = clock_.now_ + std::max<Nanos>(0, timeout);
  for (;;) {
    if (!rx_.empty() && !buffer.empty()) {
      const std::size_t n = std::min(buffer.size(), rx_.size());
      std::copy_n(rx_.begin(), n, buffer.begin());
      rx_.erase(rx_.begin(), rx_.begin() + static_cast<std::ptrdiff_t>(n));
      return {serial::IoResult::Status::kOk, n, 0};
    }
    if (clock_.now_ >= deadline) return {serial::IoResult::Status::kTimeout, 0, 0};
    const Nanos next = busy_ ? std::max(line_free_at_ + byte_time(), clock_.now_ + 1) : clock_.now_ + kIdleTick;
    step_to(std::min(deadline, next));
  }
}

serial::IoResult SimLmsLink::write(std::span<const std::uint8_t> bytes, Nanos) {
  if (unplugged_) return {serial::IoResult::Status::kOk, bytes.size(), 0};  // into the void
  if (host_baud_ == device_.baud()) {
    device_.receive(bytes, clock_.now_);
  } else {
    std::vector<std::uint8_t> garbage(bytes.size());
    for (auto& g : garbage) g = static_cast<std::uint8_t>(noise_());
    device_.receive(garbage, clock_.now_);
  }
  return {serial::IoResult::Status::kOk, bytes.size(), 0};
}

IoError SimLmsLink::set_baud(std::uint32_t baud) {
  host_baud_ = baud;
  return {};
}

IoError SimLmsLink::reopen() {
  rx_.clear();
  return {};
}

}  // namespace cairn::hil

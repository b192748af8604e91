#include "hil/cia402/sim_drive_bus.hpp"

#include <algorithm>

namespace cairn::hil {

namespace {
constexpr std::size_t kLogLimit = 200000;  // frames kept for the analyser (oldest dropped)
}

SimDriveBus::SimDriveBus(SimClock* clock, std::vector<DriveConfig> drives, Nanos tick) : clock_(clock), tick_(tick) {
  for (auto& c : drives) {
    nodes_.push_back(std::make_unique<DriveNode>(std::move(c)));
    nodes_.back()->power_on(clock_->now());
  }
}

can::SendResult SimDriveBus::send(const can::Frame& f, Nanos) {
  if (bus_off_) {
    ++stats_.tx_rejected;
    return can::SendResult::kBusOff;
  }
  ++stats_.tx;
  const Nanos now = clock_->now();
  log_.push_back({now, f, true});
  for (auto& n : nodes_) n->on_frame(f, now);
  collect(now);
  return can::SendResult::kSent;
}

bool SimDriveBus::receive(can::Frame* f, Nanos timeout) {
  const Nanos deadline = clock_->now() + std::max<Nanos>(0, timeout);
  for (;;) {
    if (!to_master_.empty()) {
      *f = to_master_.front();
      to_master_.pop_front();
      f->stamp = clock_->now();
      if (f->is_error()) {
        ++stats_.error_frames;
      } else {
        ++stats_.rx;
      }
      return true;
    }
    const Nanos now = clock_->now();
    if (now >= deadline) return false;
    advance_to(std::min(deadline, now + tick_));
  }
}

IoError SimDriveBus::restart() {
  if (clock_->now() < hold_until_) return {IoErrc::kBusOff, 0};
  bus_off_ = false;
  ++stats_.restarts;
  return {};
}

void SimDriveBus::inject_bus_off(Nanos hold) {
  bus_off_ = true;
  hold_until_ = clock_->now() + hold;
  ++stats_.bus_off;
  can::Frame err;
  err.id = can::Frame::kError | can::kErrBusOff;
  err.len = 8;
  to_master_.push_back(err);
}

void SimDriveBus::run_until(Nanos t) {
  while (clock_->now() < t) advance_to(std::min(t, clock_->now() + tick_));
}

void SimDriveBus::advance_to(Nanos t) {
  clock_->set(t);
  for (auto& n : nodes_) n->update(t);
  collect(t);
}

// Frames the drives queued go on the bus now: to the master (unless its controller is
// off the bus, when it hears nothing) and to the other drives.
void SimDriveBus::collect(Nanos now) {
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    auto& out = nodes_[i]->outbox();
    while (!out.empty()) {
      const can::Frame f = out.front();
      out.pop_front();
      log_.push_back({now, f, false});
      if (!bus_off_) to_master_.push_back(f);
      for (std::size_t j = 0; j < nodes_.size(); ++j) {
        if (j != i) nodes_[j]->on_frame(f, now);
      }
    }
  }
  while (log_.size() > kLogLimit) log_.pop_front();
}

}  // namespace cairn::hil

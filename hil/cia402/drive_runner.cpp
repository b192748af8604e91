#include "hil/cia402/drive_runner.hpp"

namespace cairn::hil {

DriveRunner::DriveRunner(std::unique_ptr<can::Port> port, DriveConfig cfg) : port_(std::move(port)), node_(std::move(cfg)) {}
DriveRunner::~DriveRunner() { stop(); }

void DriveRunner::start() {
  {
    std::lock_guard l(mutex_);
    node_.power_on(MonotonicClock::instance().now());
  }
  running_ = true;
  thread_ = std::thread([this] { run(); });
}

void DriveRunner::stop() {
  if (!running_.exchange(false)) return;
  if (thread_.joinable()) thread_.join();
}

void DriveRunner::run() {
  auto& clock = MonotonicClock::instance();
  while (running_) {
    can::Frame f;
    const bool got = port_->receive(&f, kNanosPerMilli);
    std::lock_guard l(mutex_);
    const Nanos now = clock.now();
    if (got) node_.on_frame(f, now);
    node_.update(now);
    while (!node_.outbox().empty()) {
      port_->send(node_.outbox().front(), now + kNanosPerMilli);
      node_.outbox().pop_front();
    }
  }
}

}  // namespace cairn::hil

// Runs an emulated CiA 402 drive on a CAN port in its own thread (the HIL bench's drives).
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <thread>

#include "drivers/can/can_port.hpp"
#include "hil/cia402/drive_node.hpp"

namespace cairn::hil {

class DriveRunner {
 public:
  DriveRunner(std::unique_ptr<can::Port> port, DriveConfig cfg);
  ~DriveRunner();
  void start();
  void stop();
  template <typename F>
  auto with_node(F&& f) {
    std::lock_guard l(mutex_);
    return f(node_);
  }

 private:
  void run();
  std::unique_ptr<can::Port> port_;
  DriveNode node_;
  std::mutex mutex_;
  std::thread thread_;
  std::atomic<bool> running_{false};
};

}  // namespace cairn::hil

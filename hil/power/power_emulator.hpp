// An emulated robot power board: a real libmodbus server (TCP on 127.0.0.1, or RTU over a
// pty pair joined by a relay, as protocols.md §3.5 describes) serving the register map of
// drivers/modbus/power_board.hpp from a battery model: state of charge falls with the
// current drawn, voltage follows charge and load, temperature follows current. The e-stop
// is pressed and released on command; pressed, it cuts the motor relay as the board's
// hardware would.
#pragma once

#include <atomic>
#include <mutex>
#include <string>
#include <thread>

#include "common/clock.hpp"
#include "drivers/modbus/power_board.hpp"

namespace cairn::hil {

struct BatteryConfig {
  double capacity_ah = 20.0;
  double soc = 0.9;              // 0..1 at start
  double idle_current = 1.2;     // A
  double motor_current = 4.0;    // A while the motor relay is on
  double internal_resistance = 0.05;
};

class PowerEmulator {
 public:
  enum class Link { kTcp, kRtuPty };
  PowerEmulator(Link link, modbus::RegisterMap map, BatteryConfig battery);
  ~PowerEmulator();
  PowerEmulator(const PowerEmulator&) = delete;
  PowerEmulator& operator=(const PowerEmulator&) = delete;

  /// What a driver opens: tcp:127.0.0.1:PORT or rtu:/dev/pts/N:115200.
  std::string uri() const { return uri_; }
  void press_estop(bool pressed);
  /// A fault: the board stops answering (requests are read and dropped), as when its
  /// controller hangs or the cable is pulled.
  void set_silent(bool silent) { silent_ = silent; }
  bool motor_relay() const;
  double soc() const;
  std::uint64_t requests() const { return requests_.load(); }

 private:
  void serve_tcp();
  void serve_rtu();
  void relay_ptys();
  void update_model();
  int handle(std::uint8_t* query, int len, void* ctx);

  Link link_;
  modbus::RegisterMap map_;
  BatteryConfig battery_;
  std::string uri_;
  int listen_fd_ = -1;
  int master_a_ = -1, master_b_ = -1;  // RTU: server side pty, client side pty (masters)
  std::string slave_a_;
  void* mapping_ = nullptr;            // modbus_mapping_t*
  mutable std::mutex mutex_;
  std::atomic<bool> running_{true};
  std::atomic<bool> estop_{false}, relay_{false}, silent_{false};
  std::atomic<std::uint64_t> requests_{0};
  Nanos last_update_ = 0;
  std::thread server_, relay_thread_;
};

}  // namespace cairn::hil

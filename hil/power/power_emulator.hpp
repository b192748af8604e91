// An emulated robot power board: a real libmodbus server (TCP on 127.0.0.1, or RTU over a
// pty pair joined by a relay, as protocols.md §3.5 describes) serving the register map of
// drivers/modbus/power_board.hpp from a battery model: state of charge falls with the
// current drawn, voltage follows charge and load, temperature follows current. The e-stop
// is pressed and released on command; pressed, it cuts the motor relay as the board's
// hardware would. The reset input (a momentary button) is held and let go on command.
// For timing tests it records when the e-stop input last changed and every write to the
// motor relay coil (count, value, time).
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
  /// The board's reset input (1 while held): press, let a few fast-path reads see it, release.
  void press_reset(bool held);
  /// Monotonic time of the last press_estop() that changed the input (0: never).
  Nanos estop_changed_at() const { return estop_changed_at_.load(); }
  /// Writes to the motor relay coil seen (any value), and the time of the last write of 0
  /// (motor power off) and of 1 (on); 0 = never.
  std::uint64_t relay_writes() const { return relay_writes_.load(); }
  Nanos relay_off_written_at() const { return relay_off_at_.load(); }
  Nanos relay_on_written_at() const { return relay_on_at_.load(); }
  /// A fault: the board stops answering (requests are read and dropped), as when its
  /// controller hangs or the cable is pulled.
  void set_silent(bool silent) { silent_ = silent; }
  /// A fault: the next reply is sent this late (a board or gateway hiccup).
  void delay_next_reply(Nanos delay) { reply_delay_ = delay; }
  bool motor_relay() const;
  double soc() const;
  std::uint64_t requests() const { return requests_.load(); }

 private:
  void serve_tcp();
  void serve_rtu();
  void relay_ptys();
  void update_model();
  int handle(std::uint8_t* query, int len, void* ctx);

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
  std::atomic<bool> reset_{false};
  std::atomic<Nanos> reply_delay_{0};
  std::atomic<std::uint64_t> requests_{0}, relay_writes_{0};
  std::atomic<Nanos> estop_changed_at_{0}, relay_off_at_{0}, relay_on_at_{0};
  Nanos last_update_ = 0;
  std::thread server_, relay_thread_;
};

}  // namespace cairn::hil

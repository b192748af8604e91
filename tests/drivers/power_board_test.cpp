// The power board over Modbus against the libmodbus-server emulator (TCP and RTU over a
// pty pair): readings, the safety inputs (e-stop, reset), the motor relay, errors. The
// e-stop's way from the input on the board to torque off at the drives is measured where
// it runs, on the executive's own power thread, in executive_hil_test.
#include "drivers/modbus/power_board.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include "hil/power/power_emulator.hpp"

namespace cairn {
namespace {

std::unique_ptr<modbus::PowerBoard> open_board(const std::string& uri) {
  std::string err;
  auto b = modbus::PowerBoard::open(uri, {}, 100 * kNanosPerMilli, &err);
  EXPECT_TRUE(b) << err;
  return b;
}

void check_readings_and_relay(hil::PowerEmulator& emu, modbus::PowerBoard& board) {
  modbus::PowerState s;
  modbus::PowerFault err;
  ASSERT_TRUE(board.poll(&s, &err)) << err.text();
  EXPECT_NEAR(s.soc, 90.0, 0.2);
  EXPECT_NEAR(s.voltage, 23.0 + 4.2 * 0.9 - 1.2 * 0.05, 0.02);
  EXPECT_NEAR(s.current, 1.2, 0.01);
  EXPECT_FALSE(s.estop);
  EXPECT_EQ(emu.relay_writes(), 0u);
  const Nanos before_on = MonotonicClock::instance().now();
  ASSERT_TRUE(board.set_motor_power(true, &err)) << err.text();
  EXPECT_TRUE(emu.motor_relay());
  EXPECT_EQ(emu.relay_writes(), 1u);  // the emulator records every write to the relay coil
  EXPECT_GT(emu.relay_on_written_at(), before_on);
  EXPECT_EQ(emu.relay_off_written_at(), 0);
  ASSERT_TRUE(board.poll(&s, &err)) << err.text();
  EXPECT_NEAR(s.current, 5.2, 0.01);
  // The reset input, read with the e-stop in one transaction.
  modbus::SafetyInputBits bits;
  ASSERT_TRUE(board.read_safety_inputs(&bits));
  EXPECT_FALSE(bits.estop);
  EXPECT_FALSE(bits.reset);
  emu.press_reset(true);
  ASSERT_TRUE(board.read_safety_inputs(&bits));
  EXPECT_FALSE(bits.estop);
  EXPECT_TRUE(bits.reset);
  emu.press_reset(false);
  ASSERT_TRUE(board.read_safety_inputs(&bits));
  EXPECT_FALSE(bits.reset);
  const Nanos before_press = MonotonicClock::instance().now();
  emu.press_estop(true);
  EXPECT_GE(emu.estop_changed_at(), before_press);
  ASSERT_TRUE(board.read_safety_inputs(&bits));
  EXPECT_TRUE(bits.estop);
  EXPECT_FALSE(bits.reset);
  EXPECT_EQ(board.estop_pressed(), 1);
  EXPECT_FALSE(emu.motor_relay());  // the e-stop cuts motor power on the board itself
  ASSERT_TRUE(board.set_motor_power(true, &err));
  EXPECT_FALSE(emu.motor_relay());  // and holds it off
  const Nanos before_off = MonotonicClock::instance().now();
  ASSERT_TRUE(board.set_motor_power(false, &err));
  EXPECT_GT(emu.relay_off_written_at(), before_off);
  EXPECT_EQ(emu.relay_writes(), 3u);
  emu.press_estop(false);
  EXPECT_EQ(board.estop_pressed(), 0);
  EXPECT_EQ(board.counters().errors, 0u);
}

TEST(PowerBoard, OverTcp) {
  hil::PowerEmulator emu(hil::PowerEmulator::Link::kTcp, {}, {});
  auto board = open_board(emu.uri());
  ASSERT_TRUE(board);
  check_readings_and_relay(emu, *board);
}

TEST(PowerBoard, OverRtuOnAPtyPair) {
  hil::PowerEmulator emu(hil::PowerEmulator::Link::kRtuPty, {}, {});
  usleep(100000);  // the server opens its end
  auto board = open_board(emu.uri());
  ASSERT_TRUE(board);
  check_readings_and_relay(emu, *board);
}

TEST(PowerBoard, ErrorsAreClearAndCounted) {
  std::string err;
  EXPECT_EQ(modbus::PowerBoard::open("tcp:127.0.0.1:1", {}, 100 * kNanosPerMilli, &err), nullptr);
  EXPECT_NE(err.find("cannot connect to the power board"), std::string::npos) << err;
  EXPECT_EQ(modbus::PowerBoard::open("modbus:x", {}, 100 * kNanosPerMilli, &err), nullptr);
  EXPECT_NE(err.find("expected tcp:HOST:PORT or rtu:DEVICE:BAUD"), std::string::npos) << err;
  // A map pointing at registers the board does not have: an exception reply, counted, no crash.
  hil::PowerEmulator emu(hil::PowerEmulator::Link::kTcp, {}, {});
  modbus::RegisterMap wrong;
  wrong.temperature = 40;
  auto board = modbus::PowerBoard::open(emu.uri(), wrong, 100 * kNanosPerMilli, &err);
  ASSERT_TRUE(board) << err;
  modbus::PowerState s;
  modbus::PowerFault fault;
  EXPECT_FALSE(board->poll(&s, &fault));
  EXPECT_EQ(fault.text(), "reading input registers: Illegal data address");
  EXPECT_EQ(board->counters().errors, 1u);
  // Implausible values are rejected by the decoder.
  const std::uint16_t regs[4] = {60000, 0, 500, 300};
  EXPECT_FALSE(modbus::decode_power(regs, false, {}, &s));
}

// A reply that comes after the response timeout: that read fails, and the next ones must
// not take the late reply for theirs (on TCP the link is reconnected to resynchronise).
TEST(PowerBoard, ALateReplyCostsOneReadNotAStreamOfThem) {
  hil::PowerEmulator emu(hil::PowerEmulator::Link::kTcp, {}, {});
  std::string err;
  auto board = modbus::PowerBoard::open(emu.uri(), {}, 20 * kNanosPerMilli, &err);
  ASSERT_TRUE(board) << err;
  modbus::SafetyInputBits bits;
  ASSERT_TRUE(board->read_safety_inputs(&bits));
  emu.delay_next_reply(40 * kNanosPerMilli);
  EXPECT_FALSE(board->read_safety_inputs(&bits));
  usleep(40000);  // the late reply arrives
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(board->read_safety_inputs(&bits)) << "read " << i << " after the late reply";
  EXPECT_EQ(board->counters().errors, 1u);
}

// A malformed port or baud rate is a clear error, not an exception out of std::stoi.
TEST(PowerBoard, BadPortOrBaudIsAClearErrorNotAThrow) {
  for (const char* uri : {"tcp:127.0.0.1:notaport", "tcp:127.0.0.1:", "tcp:127.0.0.1:99999999999", "tcp:127.0.0.1:70000",
                          "tcp:127.0.0.1:0", "tcp:127.0.0.1:-5", "tcp:127.0.0.1:502x"}) {
    std::string err;
    std::unique_ptr<modbus::PowerBoard> b;
    EXPECT_NO_THROW(b = modbus::PowerBoard::open(uri, {}, 100 * kNanosPerMilli, &err)) << uri;
    EXPECT_EQ(b, nullptr) << uri;
    EXPECT_NE(err.find("the TCP port must be a number in 1..65535"), std::string::npos) << uri << ": " << err;
  }
  for (const char* uri : {"rtu:/dev/ttyUSB0:fast", "rtu:/dev/ttyUSB0:", "rtu:/dev/ttyUSB0:0", "rtu:/dev/ttyUSB0:1e9"}) {
    std::string err;
    std::unique_ptr<modbus::PowerBoard> b;
    EXPECT_NO_THROW(b = modbus::PowerBoard::open(uri, {}, 100 * kNanosPerMilli, &err)) << uri;
    EXPECT_EQ(b, nullptr) << uri;
    EXPECT_NE(err.find("the baud rate must be a positive number"), std::string::npos) << uri << ": " << err;
  }
}

// One poll reads the four input registers in one request, and Modbus allows at most 125
// registers per read: a map spanning more is refused up front, not failed at every poll.
TEST(PowerBoard, RegisterMapSpanningMoreThanOneReadIsRefused) {
  modbus::RegisterMap wide;
  wide.voltage = 0;
  wide.temperature = 125;  // 0..125: 126 registers
  std::string err;
  EXPECT_FALSE(modbus::validate_register_map(wide, &err));
  EXPECT_NE(err.find("span 0..125 (126 registers); one Modbus read holds at most 125"), std::string::npos) << err;
  hil::PowerEmulator wide_emu(hil::PowerEmulator::Link::kTcp, wide, {});
  EXPECT_EQ(modbus::PowerBoard::open(wide_emu.uri(), wide, 100 * kNanosPerMilli, &err), nullptr);
  EXPECT_NE(err.find("could never be polled"), std::string::npos) << err;
  // Exactly 125 is the protocol's limit, valid, and polls.
  modbus::RegisterMap edge;
  edge.voltage = 0;
  edge.temperature = 124;
  err.clear();
  EXPECT_TRUE(modbus::validate_register_map(edge, &err)) << err;
  hil::PowerEmulator emu(hil::PowerEmulator::Link::kTcp, edge, {});
  auto board = modbus::PowerBoard::open(emu.uri(), edge, 100 * kNanosPerMilli, &err);
  ASSERT_TRUE(board) << err;
  modbus::PowerState s;
  modbus::PowerFault fault;
  EXPECT_TRUE(board->poll(&s, &fault)) << fault.text();
  EXPECT_NEAR(s.soc, 90.0, 0.2);
}

}  // namespace
}  // namespace cairn

#include "drivers/modbus/power_config.hpp"

namespace cairn {
namespace {

TEST(PowerBoard, SafetyInputsMustBeDistinctAndReadableInOneRequest) {
  modbus::RegisterMap m;
  std::string err;
  EXPECT_TRUE(modbus::validate_register_map(m, &err)) << err;
  m.reset_input = m.estop;
  EXPECT_FALSE(modbus::validate_register_map(m, &err));
  EXPECT_NE(err.find("the e-stop and reset inputs are both discrete input 0"), std::string::npos) << err;
  m.reset_input = m.estop + modbus::kMaxSafetyInputSpan;
  EXPECT_FALSE(modbus::validate_register_map(m, &err));
  EXPECT_NE(err.find("must lie within 16 bits"), std::string::npos) << err;
  m.reset_input = m.estop + modbus::kMaxSafetyInputSpan - 1;
  EXPECT_TRUE(modbus::validate_register_map(m, &err)) << err;
  // Read from the board at the far end of the span.
  hil::PowerEmulator emu(hil::PowerEmulator::Link::kTcp, m, {});
  auto board = modbus::PowerBoard::open(emu.uri(), m, 100 * kNanosPerMilli, &err);
  ASSERT_TRUE(board) << err;
  emu.press_reset(true);
  modbus::SafetyInputBits bits;
  ASSERT_TRUE(board->read_safety_inputs(&bits));
  EXPECT_TRUE(bits.reset);
  EXPECT_FALSE(bits.estop);
}

TEST(PowerBoard, RegisterMapFromConfig) {
  auto doc = ConfigDocument::parse("[power]\nslave = 3\nvoltage_register = 10\ncurrent_register = 11\nsoc_register = 12\n"
                                   "temperature_register = 13\nestop_input = 2\nvoltage_scale = 0.001\n",
                                   "robot.toml");
  const auto m = modbus::register_map_from_config(doc.root().section("power"));
  EXPECT_EQ(m.slave, 3);
  EXPECT_EQ(m.temperature, 13);
  EXPECT_EQ(m.estop, 2);
  EXPECT_DOUBLE_EQ(m.voltage_scale, 0.001);
  EXPECT_NO_THROW(doc.finish());
  auto dup = ConfigDocument::parse("[power]\nvoltage_register = 1\n", "robot.toml");  // collides with current (1)
  EXPECT_THROW(modbus::register_map_from_config(dup.root().section("power")), ConfigError);
  // Registers 0..125 cannot be read in one Modbus request: refused with the reason.
  auto wide = ConfigDocument::parse("[power]\nvoltage_register = 0\ntemperature_register = 125\n", "robot.toml");
  try {
    modbus::register_map_from_config(wide.root().section("power"));
    ADD_FAILURE() << "a map spanning 126 registers was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("one Modbus read holds at most 125"), std::string::npos) << e.what();
  }
  auto edge = ConfigDocument::parse("[power]\nvoltage_register = 0\ntemperature_register = 124\n", "robot.toml");
  EXPECT_NO_THROW(modbus::register_map_from_config(edge.root().section("power")));
}

}  // namespace
}  // namespace cairn

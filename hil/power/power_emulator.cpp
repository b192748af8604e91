#include "hil/power/power_emulator.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <pty.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace cairn::hil {

namespace {
modbus_mapping_t* as_mapping(void* p) { return static_cast<modbus_mapping_t*>(p); }
}  // namespace

PowerEmulator::PowerEmulator(Link link, modbus::RegisterMap map, BatteryConfig battery)
    : map_(map), battery_(battery) {
  const int regs = std::max({map_.voltage, map_.current, map_.soc, map_.temperature}) + 1;
  mapping_ = modbus_mapping_new(map_.motor_relay + 1, std::max(map_.estop, map_.reset_input) + 1, 0, regs);
  if (!mapping_) throw std::runtime_error("power emulator: modbus_mapping_new failed");
  last_update_ = MonotonicClock::instance().now();
  update_model();
  if (link == Link::kTcp) {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const int one = 1;
    setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);  // loopback only
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(listen_fd_, 4) != 0) {
      throw std::runtime_error(std::string("power emulator: cannot listen: ") + std::strerror(errno));
    }
    socklen_t len = sizeof a;
    getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
    uri_ = "tcp:127.0.0.1:" + std::to_string(ntohs(a.sin_port));
    server_ = std::thread([this] { serve_tcp(); });
  } else {
    int sa = -1, sb = -1;
    char na[128], nb[128];
    if (openpty(&master_a_, &sa, na, nullptr, nullptr) != 0 || openpty(&master_b_, &sb, nb, nullptr, nullptr) != 0) {
      throw std::runtime_error(std::string("power emulator: openpty: ") + std::strerror(errno));
    }
    for (int fd : {master_a_, master_b_, sa, sb}) {
      termios t{};
      tcgetattr(fd, &t);
      cfmakeraw(&t);
      tcsetattr(fd, TCSANOW, &t);
    }
    ::close(sa);  // the server and the client open the slaves by name
    ::close(sb);
    slave_a_ = na;
    uri_ = std::string("rtu:") + nb + ":115200";
    relay_thread_ = std::thread([this] { relay_ptys(); });
    server_ = std::thread([this] { serve_rtu(); });
  }
}

PowerEmulator::~PowerEmulator() {
  running_ = false;
  if (server_.joinable()) server_.join();
  if (relay_thread_.joinable()) relay_thread_.join();
  if (listen_fd_ >= 0) ::close(listen_fd_);
  if (master_a_ >= 0) ::close(master_a_);
  if (master_b_ >= 0) ::close(master_b_);
  modbus_mapping_free(as_mapping(mapping_));
}

void PowerEmulator::press_estop(bool pressed) {
  std::lock_guard l(mutex_);
  if (estop_ != pressed) estop_changed_at_ = MonotonicClock::instance().now();
  estop_ = pressed;
  if (pressed) relay_ = false;  // the board's hardware cuts motor power
  update_model();
}

void PowerEmulator::press_reset(bool held) {
  std::lock_guard l(mutex_);
  reset_ = held;
  update_model();
}

bool PowerEmulator::motor_relay() const {
  std::lock_guard l(mutex_);  // consistent with a reply in flight (handle() holds the lock)
  return relay_.load();
}

double PowerEmulator::soc() const {
  std::lock_guard l(mutex_);
  return battery_.soc;
}

// Battery model, advanced to now; writes the registers the server answers from.
void PowerEmulator::update_model() {
  const Nanos now = MonotonicClock::instance().now();
  const double dt = nanos_to_seconds(now - last_update_);
  last_update_ = now;
  const double current = battery_.idle_current + (relay_ ? battery_.motor_current : 0.0);
  battery_.soc = std::max(0.0, battery_.soc - current * dt / 3600.0 / battery_.capacity_ah);
  const double voltage = 23.0 + 4.2 * battery_.soc - current * battery_.internal_resistance;
  const double temperature = 30.0 + 0.5 * current;
  modbus_mapping_t* m = as_mapping(mapping_);
  m->tab_input_registers[map_.voltage] = static_cast<std::uint16_t>(std::lround(voltage / map_.voltage_scale));
  m->tab_input_registers[map_.current] = static_cast<std::uint16_t>(static_cast<std::int16_t>(std::lround(current / map_.current_scale)));
  m->tab_input_registers[map_.soc] = static_cast<std::uint16_t>(std::lround(battery_.soc * 100.0 / map_.soc_scale));
  m->tab_input_registers[map_.temperature] =
      static_cast<std::uint16_t>(static_cast<std::int16_t>(std::lround(temperature / map_.temperature_scale)));
  m->tab_input_bits[map_.estop] = estop_ ? 1 : 0;
  m->tab_input_bits[map_.reset_input] = reset_ ? 1 : 0;
  m->tab_bits[map_.motor_relay] = relay_ ? 1 : 0;
}

int PowerEmulator::handle(std::uint8_t* query, int len, void* ctx) {
  if (silent_) return 0;
  if (const Nanos d = reply_delay_.exchange(0); d > 0) ::usleep(static_cast<useconds_t>(d / kNanosPerMicro));
  std::lock_guard l(mutex_);
  update_model();
  // Record writes to the relay coil (function 5, write single coil) for the timing tests,
  // before the reply: a client that has its reply must find the write recorded.
  const int h = modbus_get_header_length(static_cast<modbus_t*>(ctx));
  if (len >= h + 5 && query[h] == 0x05 && ((query[h + 1] << 8) | query[h + 2]) == map_.motor_relay) {
    const Nanos now = MonotonicClock::instance().now();
    ++relay_writes_;
    (query[h + 3] == 0xFF ? relay_on_at_ : relay_off_at_) = now;
  }
  const int rc = modbus_reply(static_cast<modbus_t*>(ctx), query, len, as_mapping(mapping_));
  // A write to the relay coil switches motor power, unless the e-stop holds it off.
  relay_ = as_mapping(mapping_)->tab_bits[map_.motor_relay] != 0 && !estop_;
  as_mapping(mapping_)->tab_bits[map_.motor_relay] = relay_ ? 1 : 0;
  ++requests_;
  return rc;
}

void PowerEmulator::serve_tcp() {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", 0);
  modbus_set_slave(ctx, map_.slave);
  modbus_set_response_timeout(ctx, 0, 10000);  // libmodbus sleeps this long before answering a bad request
  std::uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
  int client = -1;
  while (running_) {
    if (client < 0) {
      pollfd p{listen_fd_, POLLIN, 0};
      if (poll(&p, 1, 50) <= 0) continue;
      int lfd = listen_fd_;
      client = modbus_tcp_accept(ctx, &lfd);
      continue;
    }
    pollfd p{client, POLLIN, 0};
    if (poll(&p, 1, 50) <= 0) continue;
    const int n = modbus_receive(ctx, query);
    if (n > 0) {
      handle(query, n, ctx);
    } else if (n < 0) {
      ::close(client);  // peer gone or broken request: wait for the next client
      modbus_set_socket(ctx, -1);
      client = -1;
    }
  }
  if (client >= 0) ::close(client);
  modbus_free(ctx);
}

void PowerEmulator::relay_ptys() {
  std::uint8_t buf[512];
  while (running_) {
    pollfd p[2] = {{master_a_, POLLIN, 0}, {master_b_, POLLIN, 0}};
    if (poll(p, 2, 50) <= 0) continue;
    for (int i = 0; i < 2; ++i) {
      if (!(p[i].revents & POLLIN)) continue;
      const ssize_t n = ::read(p[i].fd, buf, sizeof buf);
      if (n > 0) {
        const ssize_t w = ::write(i == 0 ? master_b_ : master_a_, buf, static_cast<std::size_t>(n));
        (void)w;
      }
    }
  }
}

void PowerEmulator::serve_rtu() {
  modbus_t* ctx = modbus_new_rtu(slave_a_.c_str(), 115200, 'N', 8, 1);
  modbus_set_slave(ctx, map_.slave);
  modbus_set_response_timeout(ctx, 0, 10000);
  modbus_set_indication_timeout(ctx, 0, 100000);  // wake up to check for shutdown
  if (modbus_connect(ctx) != 0) {
    modbus_free(ctx);
    return;
  }
  std::uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH];
  while (running_) {
    const int n = modbus_receive(ctx, query);
    if (n > 0) {
      handle(query, n, ctx);
    } else if (n == 0) {
      modbus_flush(ctx);  // a request for another slave: avoid the desynchronisation pitfall
    }
  }
  modbus_close(ctx);
  modbus_free(ctx);
}

}  // namespace cairn::hil

// CANopen speed: frames/s through the user-space CAN bus (beside a raw Unix datagram
// socketpair as the baseline, in the same run), and the cost of one control cycle of the
// drive master with two emulated drives (in-process, no sockets: the master's own work).
#include <benchmark/benchmark.h>
#include <sys/socket.h>
#include <unistd.h>

#include "drivers/can/can_hub.hpp"
#include "drivers/canopen/drive_master.hpp"
#include "hil/cia402/drive_node.hpp"

using namespace cairn;

namespace {

void BM_RawDatagramBaseline(benchmark::State& st) {
  int sv[2];
  socketpair(AF_UNIX, SOCK_DGRAM, 0, sv);
  std::uint8_t buf[16] = {};
  for (auto _ : st) {
    const ssize_t w = ::send(sv[0], buf, sizeof buf, 0);
    const ssize_t r = ::recv(sv[1], buf, sizeof buf, 0);
    benchmark::DoNotOptimize(w + r);
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations()));
  close(sv[0]);
  close(sv[1]);
}

// One frame from port A to port B through the hub (send, hub forward, receive).
void BM_UserSpaceBusFrame(benchmark::State& st) {
  can::Hub hub("/tmp/cairn-bench-can-" + std::to_string(getpid()) + ".sock");
  std::string err;
  auto a = can::UcanPort::open(hub.path(), 1, false, &err);
  auto b = can::UcanPort::open(hub.path(), 2, false, &err);
  while (hub.ports() < 2) usleep(1000);
  can::Frame f;
  f.id = 0x181;
  f.len = 8;
  can::Frame got;
  for (auto _ : st) {
    a->send(f, MonotonicClock::instance().now() + kNanosPerSecond);
    if (!b->receive(&got, kNanosPerSecond)) st.SkipWithError("frame lost");
  }
  st.SetItemsProcessed(static_cast<std::int64_t>(st.iterations()));
}

// A CAN "bus" wiring the master straight to emulated drives, so only computation is timed.
class DirectBus : public can::Port {
 public:
  explicit DirectBus(std::vector<hil::DriveNode>* nodes, SimClock* clock) : nodes_(nodes), clock_(clock) {}
  can::SendResult send(const can::Frame& f, Nanos) override {
    for (auto& n : *nodes_) n.on_frame(f, clock_->now());
    ++stats_.tx;
    return can::SendResult::kSent;
  }
  bool receive(can::Frame* f, Nanos) override {
    for (auto& n : *nodes_) {
      n.update(clock_->now());
      if (!n.outbox().empty()) {
        *f = n.outbox().front();
        f->stamp = clock_->now();
        n.outbox().pop_front();
        ++stats_.rx;
        return true;
      }
    }
    return false;
  }
  const can::BusStats& stats() const override { return stats_; }
  bool bus_off() const override { return false; }
  IoError restart() override { return {}; }
  std::string describe() const override { return "direct"; }
  void pause(Nanos until) override { clock_->set(until); }  // simulated time, not the machine's

 private:
  std::vector<hil::DriveNode>* nodes_;
  SimClock* clock_;
  can::BusStats stats_;
};

void BM_ControlCycle(benchmark::State& st) {
  SimClock clock(kNanosPerSecond);
  std::vector<hil::DriveNode> nodes;
  for (std::uint8_t id : {std::uint8_t{1}, std::uint8_t{2}}) {
    hil::DriveConfig c;
    c.node = id;
    c.boot_time_s = 0;
    nodes.emplace_back(c);
    nodes.back().power_on(clock.now());
  }
  DirectBus bus(&nodes, &clock);
  canopen::MasterConfig mc;
  mc.io_slice = 0;
  canopen::DriveMaster master(&bus, &clock, mc);
  for (int i = 0; i < 2000 && !master.all_enabled(); ++i) {
    clock.advance(kNanosPerMilli);
    master.step();
  }
  if (!master.all_enabled()) st.SkipWithError("drives never enabled");
  const std::int32_t v[] = {1000, -1000};
  master.command(v);
  for (auto _ : st) {
    clock.advance(mc.sync_period);
    master.step();  // receive + supervise + RPDOs + SYNC (and the drives' replies)
  }
  st.counters["syncs"] = static_cast<double>(master.syncs());
  st.counters["enabled"] = master.all_enabled() ? 1 : 0;
  st.counters["feedback"] = static_cast<double>(master.feedback(0).updates);
  st.counters["drive_syncs"] = static_cast<double>(nodes[0].syncs());
}

}  // namespace

BENCHMARK(BM_RawDatagramBaseline);
BENCHMARK(BM_UserSpaceBusFrame);
BENCHMARK(BM_ControlCycle);
BENCHMARK_MAIN();

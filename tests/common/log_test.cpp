#include "common/log.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <mutex>
#include <thread>
#include <vector>

namespace cairn {
namespace {

struct Captured {
  std::mutex m;
  std::vector<std::string> lines;
  Logger::Sink sink() {
    return [this](const LogRecord&, const std::string& line) {
      std::lock_guard l(m);
      lines.push_back(line);
    };
  }
};

TEST(LogFormat, PlaceholdersAndSpecs) {
  Logger log(16);
  Captured cap;
  log.set_sink(cap.sink());
  log.log(LogLevel::kInfo, "test", "a={} b={:.2f} c={} d={:x} e={} {{literal}} f={}", 42, 3.14159, "text", 255u, true,
          std::string_view("view"));
  log.log(LogLevel::kWarn, "test", "missing {} {}", 1);
  log.drain();
  ASSERT_EQ(cap.lines.size(), 2u);
  EXPECT_NE(cap.lines[0].find("a=42 b=3.14 c=text d=ff e=true {literal} f=view"), std::string::npos) << cap.lines[0];
  EXPECT_NE(cap.lines[0].find("info"), std::string::npos);
  EXPECT_NE(cap.lines[1].find("missing 1 {?}"), std::string::npos);
  EXPECT_NE(cap.lines[1].find("warn"), std::string::npos);
}

TEST(LogFormat, LongTextIsTruncatedNotOverflowed) {
  Logger log(4);
  Captured cap;
  log.set_sink(cap.sink());
  const std::string big(500, 'x');
  log.log(LogLevel::kInfo, "t", "{}|{}", big, big);
  log.drain();
  ASSERT_EQ(cap.lines.size(), 1u);
  EXPECT_LT(cap.lines[0].size(), LogRecord::kTextBytes + 64);
  // The first argument fills the record's text; the second finds no room and reads as
  // "", never as whatever lies past the buffer.
  const std::string& line = cap.lines[0];
  const std::size_t bar = line.rfind('|');
  ASSERT_NE(bar, std::string::npos) << line;
  EXPECT_EQ(line.find_first_not_of('x', line.find('x')), bar) << line;
  EXPECT_EQ(line.find_first_not_of("\n", bar + 1), std::string::npos) << line;
}

TEST(Logger, MinLevelFilters) {
  Logger log(8);
  Captured cap;
  log.set_sink(cap.sink());
  log.set_min_level(LogLevel::kWarn);
  log.log(LogLevel::kInfo, "t", "hidden");
  log.log(LogLevel::kError, "t", "shown");
  log.drain();
  ASSERT_EQ(cap.lines.size(), 1u);
}

TEST(Logger, FullRingDropsAndCountsAndReports) {
  Logger log(8);
  Captured cap;
  log.set_sink(cap.sink());
  for (int i = 0; i < 20; ++i) log.log(LogLevel::kInfo, "t", "n={}", i);
  EXPECT_EQ(log.dropped(), 12u);
  log.drain();
  ASSERT_EQ(cap.lines.size(), 9u);  // 8 records + the drop report
  EXPECT_NE(cap.lines.back().find("12 record(s) dropped"), std::string::npos);
  // The ring is usable again after draining.
  log.log(LogLevel::kInfo, "t", "again");
  EXPECT_EQ(log.drain(), 1u);
}

// What the sink received from producers logging "thread T msg I": per thread, the message
// numbers in arrival order; and the sum of the drop reports.
struct Tally {
  std::vector<std::vector<int>> per_thread;
  std::uint64_t messages = 0, reported_dropped = 0, other = 0;
};
Tally tally(const std::vector<std::string>& lines, int threads) {
  Tally t;
  t.per_thread.resize(static_cast<std::size_t>(threads));
  for (const std::string& line : lines) {
    int th = -1, msg = -1;
    unsigned long long lost = 0;
    const std::size_t at = line.find("thread ");
    const std::size_t lost_at = line.find("log: ");
    if (at != std::string::npos && std::sscanf(line.c_str() + at, "thread %d msg %d", &th, &msg) == 2 && th >= 0 &&
        th < threads) {
      t.per_thread[static_cast<std::size_t>(th)].push_back(msg);
      ++t.messages;
    } else if (lost_at != std::string::npos && std::sscanf(line.c_str() + lost_at, "log: %llu record(s) dropped", &lost) == 1) {
      t.reported_dropped += lost;
    } else {
      ++t.other;
    }
  }
  return t;
}

// Strictly increasing: nothing duplicated, one producer's records in its order.
bool increasing(const std::vector<int>& v) {
  for (std::size_t i = 1; i < v.size(); ++i) {
    if (v[i] <= v[i - 1]) return false;
  }
  return true;
}

// Fewer records than the ring holds: none may be dropped, whatever the drain thread does;
// every one arrives, once, in each producer's order.
TEST(Logger, ManyProducersWithinCapacityDeliverEveryRecord) {
  Logger log(256);
  Captured cap;
  log.set_sink(cap.sink());
  log.start();
  constexpr int kThreads = 4, kPerThread = 60;  // 240 < 256
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&log, t] {
      for (int i = 0; i < kPerThread; ++i) log.log(LogLevel::kInfo, "mt", "thread {} msg {}", t, i);
    });
  }
  for (auto& th : threads) th.join();
  log.stop();
  EXPECT_EQ(log.dropped(), 0u);
  EXPECT_EQ(log.written(), static_cast<std::uint64_t>(kThreads * kPerThread));
  const Tally got = tally(cap.lines, kThreads);
  EXPECT_EQ(got.messages, static_cast<std::uint64_t>(kThreads * kPerThread));
  EXPECT_EQ(got.other, 0u);
  for (int t = 0; t < kThreads; ++t) {
    const auto& v = got.per_thread[static_cast<std::size_t>(t)];
    ASSERT_EQ(v.size(), static_cast<std::size_t>(kPerThread)) << "thread " << t;
    for (int i = 0; i < kPerThread; ++i) EXPECT_EQ(v[static_cast<std::size_t>(i)], i) << "thread " << t;
  }
}

// More than the ring holds, as fast as possible: drops are allowed, but every record is
// either delivered to the sink or counted and reported as dropped, and records do arrive.
TEST(Logger, ManyProducersOneDrainThreadLoseNothingUncounted) {
  Logger log(256);
  Captured cap;
  log.set_sink(cap.sink());
  log.start();
  constexpr int kThreads = 4, kPerThread = 5000;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&log, t] {
      for (int i = 0; i < kPerThread; ++i) log.log(LogLevel::kInfo, "mt", "thread {} msg {}", t, i);
    });
  }
  for (auto& th : threads) th.join();
  log.stop();
  const std::uint64_t total = kThreads * kPerThread;
  EXPECT_EQ(log.written() + log.dropped(), total);
  const Tally got = tally(cap.lines, kThreads);
  EXPECT_EQ(got.messages, log.written()) << "the sink saw what the logger says it wrote";
  EXPECT_EQ(got.reported_dropped, log.dropped()) << "every drop was reported";
  EXPECT_EQ(got.other, 0u);
  // At least the first ring-full arrives: the ring takes 256 records before it can drop any.
  EXPECT_GE(got.messages, 256u);
  for (int t = 0; t < kThreads; ++t) {
    EXPECT_TRUE(increasing(got.per_thread[static_cast<std::size_t>(t)])) << "thread " << t << " out of order or duplicated";
  }
}

}  // namespace
}  // namespace cairn

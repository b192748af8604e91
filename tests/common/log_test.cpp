#include "common/log.hpp"

#include <gtest/gtest.h>

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
}

}  // namespace
}  // namespace cairn

// LMS2xx codec speed: stream parsing throughput (MB/s) and per-scan parse + decode
// latency, for 181-, 361- and 401-beam telegrams (401 is the most one B0 telegram holds), with the CRC alone as the baseline.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "drivers/sick/lms_codec.hpp"

using namespace cairn::lms;

namespace {

Frame scan_telegram(int beams) {
  std::vector<std::uint8_t> data(2 + 2 * static_cast<std::size_t>(beams) + 1);
  const std::uint16_t word = static_cast<std::uint16_t>(beams | (1 << 14));
  data[0] = static_cast<std::uint8_t>(word & 0xFF);
  data[1] = static_cast<std::uint8_t>(word >> 8);
  std::mt19937 rng(1);
  for (int i = 0; i < beams; ++i) {
    const std::uint16_t v = static_cast<std::uint16_t>(500 + rng() % 20000);
    data[2 + 2 * i] = static_cast<std::uint8_t>(v & 0xFF);
    data[3 + 2 * i] = static_cast<std::uint8_t>(v >> 8);
  }
  Frame f;
  encode(kReplyAddress, kReplyValues, data, &f);
  return f;
}

void BM_Crc16(benchmark::State& st) {
  const Frame f = scan_telegram(static_cast<int>(st.range(0)));
  for (auto _ : st) benchmark::DoNotOptimize(crc16({f.bytes.data(), f.size - 2}));
  st.SetBytesProcessed(static_cast<std::int64_t>(st.iterations()) * static_cast<std::int64_t>(f.size));
}

// Bytes as they come off the line (4 KiB reads), parsed into telegrams and decoded.
void BM_ParseStream(benchmark::State& st) {
  const Frame f = scan_telegram(static_cast<int>(st.range(0)));
  std::vector<std::uint8_t> stream;
  for (int i = 0; i < 64; ++i) stream.insert(stream.end(), f.bytes.begin(), f.bytes.begin() + static_cast<long>(f.size));
  Parser p(kReplyAddress);
  ScanValues v;
  std::size_t scans = 0;
  for (auto _ : st) {
    for (std::size_t off = 0; off < stream.size(); off += 4096) {
      std::span<const std::uint8_t> rest(stream.data() + off, std::min<std::size_t>(4096, stream.size() - off));
      while (!rest.empty()) {
        std::size_t used = 0;
        if (p.feed(rest, &used) == Parser::Event::kTelegram) scans += decode_values(p.telegram(), 0x05, &v);
        rest = rest.subspan(used);
      }
    }
  }
  benchmark::DoNotOptimize(scans);
  st.SetBytesProcessed(static_cast<std::int64_t>(st.iterations()) * static_cast<std::int64_t>(stream.size()));
  st.counters["scans/s"] = benchmark::Counter(static_cast<double>(scans), benchmark::Counter::kIsRate);
}

// One whole telegram handed to the parser at once, then decoded: per-scan latency.
void BM_ParseOneScan(benchmark::State& st) {
  const Frame f = scan_telegram(static_cast<int>(st.range(0)));
  Parser p(kReplyAddress);
  ScanValues v;
  for (auto _ : st) {
    std::size_t used = 0;
    p.feed(f.view(), &used);
    benchmark::DoNotOptimize(decode_values(p.telegram(), 0x05, &v));
  }
  st.SetBytesProcessed(static_cast<std::int64_t>(st.iterations()) * static_cast<std::int64_t>(f.size));
}

}  // namespace

BENCHMARK(BM_Crc16)->Arg(181)->Arg(361)->Arg(401);
BENCHMARK(BM_ParseStream)->Arg(181)->Arg(361)->Arg(401);
BENCHMARK(BM_ParseOneScan)->Arg(181)->Arg(361)->Arg(401);
BENCHMARK_MAIN();

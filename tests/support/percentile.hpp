// Test support: the p-quantile of a sample (nearest rank, p in [0, 1]; 1 = the maximum),
// as the benchmarks report latencies. 0 for an empty sample.
#pragma once

#include <algorithm>
#include <vector>

namespace cairn::testing {

inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

}  // namespace cairn::testing

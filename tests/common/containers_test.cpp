#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include "common/fixed_vector.hpp"
#include "common/latest_box.hpp"
#include "common/ring_buffer.hpp"
#include "common/spsc_queue.hpp"

namespace cairn {
namespace {

TEST(FixedVector, RefusesAndCountsPastCapacity) {
  FixedVector<int> v(3);
  EXPECT_TRUE(v.push_back(1));
  EXPECT_TRUE(v.push_back(2));
  EXPECT_TRUE(v.push_back(3));
  EXPECT_TRUE(v.full());
  EXPECT_FALSE(v.push_back(4));
  EXPECT_EQ(v.emplace_slot(), nullptr);
  EXPECT_EQ(v.size(), 3u);
  EXPECT_EQ(v.overflows(), 2u);
  EXPECT_EQ(v[2], 3);
  EXPECT_THROW(v.at(3), std::out_of_range);
  v.clear();
  EXPECT_TRUE(v.empty());
  EXPECT_TRUE(v.push_back(7));
  int sum = 0;
  for (int x : v) sum += x;
  EXPECT_EQ(sum, 7);
}

TEST(FixedVector, ZeroCapacityNeverAccepts) {
  FixedVector<int> v(0);
  EXPECT_FALSE(v.push_back(1));
  EXPECT_EQ(v.overflows(), 1u);
}

TEST(RingBuffer, RejectPolicyKeepsOldest) {
  RingBuffer<int> r(2, WhenFull::kReject);
  EXPECT_TRUE(r.push(1));
  EXPECT_TRUE(r.push(2));
  EXPECT_FALSE(r.push(3));
  EXPECT_EQ(r.overflows(), 1u);
  int x = 0;
  ASSERT_TRUE(r.pop(&x));
  EXPECT_EQ(x, 1);
}

TEST(RingBuffer, OverwritePolicyKeepsNewestAndCountsDrops) {
  RingBuffer<int> r(3, WhenFull::kOverwriteOldest);
  for (int i = 1; i <= 5; ++i) EXPECT_TRUE(r.push(i));
  EXPECT_EQ(r.size(), 3u);
  EXPECT_EQ(r.overflows(), 2u);
  EXPECT_EQ(r.oldest(), 3);
  EXPECT_EQ(r.newest(), 5);
  EXPECT_EQ(r[1], 4);
}

TEST(SpscQueue, FifoAndOverflow) {
  SpscQueue<int> q(4);
  EXPECT_EQ(q.capacity(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(q.push(i));
  EXPECT_FALSE(q.push(99));
  EXPECT_EQ(q.overflows(), 1u);
  EXPECT_EQ(q.size(), 4u);
  int x = -1;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(q.pop(&x));
    EXPECT_EQ(x, i);
  }
  EXPECT_FALSE(q.pop(&x));
}

// Waiting for the other thread: yield, and after a run of misses sleep briefly, so the two
// threads share one core (or a qemu-user emulation) instead of burning whole time slices.
class Backoff {
 public:
  void miss() {
    if (++misses_ < 64) {
      std::this_thread::yield();
    } else {
      std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
  }
  void hit() { misses_ = 0; }

 private:
  int misses_ = 0;
};

TEST(SpscQueue, TwoThreadsTransferEverythingInOrder) {
  SpscQueue<std::uint64_t> q(64);
  constexpr std::uint64_t kCount = 200000;
  std::atomic<bool> was_full{false};
  std::thread producer([&] {
    Backoff backoff;
    for (std::uint64_t i = 0; i < kCount;) {
      if (q.push(i)) {
        ++i;
        backoff.hit();
      } else {
        was_full.store(true, std::memory_order_release);
        backoff.miss();
      }
    }
  });
  // The consumer starts once the producer has met a full queue: overflow is then certain,
  // not a matter of which thread the scheduler favoured.
  while (!was_full.load(std::memory_order_acquire)) std::this_thread::yield();
  std::uint64_t expected = 0, out_of_order = 0, first_bad = 0, got = 0;
  Backoff backoff;
  while (expected < kCount) {
    std::uint64_t v;
    if (q.pop(&v)) {
      backoff.hit();
      if (v != expected && out_of_order++ == 0) first_bad = v;
      expected = v + 1;  // keep going (the producer must be joined, never abandoned)
      ++got;
    } else {
      backoff.miss();
    }
  }
  producer.join();
  EXPECT_EQ(out_of_order, 0u) << "first out-of-order value " << first_bad;
  EXPECT_EQ(got, kCount);
  EXPECT_FALSE(q.pop(&expected)) << "nothing left over";
  EXPECT_GT(q.overflows(), 0u);  // the producer met a full queue and was told so
}

struct Big {
  std::uint64_t a, b, c, d;  // a torn read would show unequal fields
};

TEST(LatestBox, ReaderSeesNewestAndNeverTorn) {
  LatestBox<Big> box;
  Big out{};
  EXPECT_FALSE(box.read(&out));
  box.write({1, 1, 1, 1});
  box.write({2, 2, 2, 2});
  EXPECT_TRUE(box.read(&out));
  EXPECT_EQ(out.a, 2u);
  EXPECT_FALSE(box.read(&out));
  EXPECT_EQ(out.d, 2u);

  LatestBox<Big> shared;
  constexpr std::uint64_t kWrites = 200000;
  std::thread writer([&] {
    for (std::uint64_t i = 1; i <= kWrites; ++i) shared.write({i, i, i, i});
  });
  std::uint64_t last = 0, torn = 0, backwards = 0, fresh = 0;
  Backoff backoff;
  while (last < kWrites) {
    Big b{};
    if (!shared.read(&b)) {  // nothing new: let the writer run
      backoff.miss();
      continue;
    }
    backoff.hit();
    ++fresh;
    if (b.a != b.b || b.a != b.c || b.a != b.d) ++torn;
    if (b.a < last) ++backwards;  // never goes back in time
    last = std::max(last, b.a);
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);
  EXPECT_GT(fresh, 0u);
  EXPECT_EQ(shared.writes(), kWrites);
}

}  // namespace
}  // namespace cairn

#include <gtest/gtest.h>

#include <atomic>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "core/parallel.h"

namespace bareskin {
namespace {

TEST(Parallel, VisitsEveryIndexExactlyOnce) {
  for (int threads : {1, 2, 5}) {
    set_num_threads(threads);
    std::vector<std::atomic<int>> hits(10007);
    parallel_for(0, 10007, [&](int64_t b, int64_t e) {
      for (int64_t i = b; i < e; ++i) ++hits[size_t(i)];
    }, 3);
    for (const auto& h : hits) ASSERT_EQ(h.load(), 1);
  }
}

TEST(Parallel, NestedCallsRunAndExceptionsPropagate) {
  set_num_threads(2);
  std::atomic<int64_t> sum{0};
  parallel_for(0, 8, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      parallel_for(0, 100, [&](int64_t b2, int64_t e2) {
        for (int64_t k = b2; k < e2; ++k) sum += k;
      });
    }
  });
  EXPECT_EQ(sum.load(), 8 * 4950);
  EXPECT_THROW(parallel_for(0, 100, [](int64_t b, int64_t) {
    if (b > 0) throw std::runtime_error("boom");
  }), std::runtime_error);
}

}  // namespace
}  // namespace bareskin

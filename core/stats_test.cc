#include <gtest/gtest.h>

#include <vector>

#include "core/stats.h"

namespace bareskin {
namespace {

TEST(Stats, MedianAveragesTheMiddlePairAndQuantileTakesARank) {
  EXPECT_EQ(median({}), 0.0);
  EXPECT_EQ(median({5, 1, 3}), 3.0);
  EXPECT_EQ(median({7, 1, 4, 2}), 3.0);  // (2 + 4) / 2, whatever the order
  EXPECT_EQ(median({-1, 100, -1, 100}), 49.5);
  EXPECT_EQ(quantile({7, 1, 4, 2}, 0.5), 4.0);  // nearest rank
  EXPECT_EQ(quantile({7, 1, 4, 2}, 1.0), 7.0);
}

}  // namespace
}  // namespace bareskin

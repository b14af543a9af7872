#include <gtest/gtest.h>

#include "stream/slab_ring.h"

namespace isoslab {
namespace {

TEST(SlabRing, KeepsTheLastCapacitySlicesAndEvictsOlderOnes) {
  SlabRing ring(6, 3);
  EXPECT_EQ(ring.bytes(), 3 * 6 * sizeof(float));
  for (std::int64_t k = 0; k < 5; ++k) {
    auto slot = ring.acquire(k);
    ASSERT_EQ(slot.size(), 6u);
    std::fill(slot.begin(), slot.end(), static_cast<float>(k));
  }
  EXPECT_EQ(ring.slice(0), nullptr);
  EXPECT_EQ(ring.slice(1), nullptr);
  EXPECT_EQ(ring.slice(-1), nullptr);
  for (std::int64_t k = 2; k < 5; ++k) {
    ASSERT_NE(ring.slice(k), nullptr);
    EXPECT_EQ(ring.slice(k)[5], static_cast<float>(k));
  }
  // A view stays valid until capacity more slices have been acquired.
  const float* two = ring.slice(2);
  ring.acquire(5);
  EXPECT_EQ(ring.slice(2), nullptr);
  EXPECT_EQ(ring.slice(5), two);  // slot reuse
}

}  // namespace
}  // namespace isoslab

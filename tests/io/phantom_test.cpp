#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/error.h"
#include "io/phantom.h"

namespace isoslab {
namespace {

std::string errorOf(const std::string& spec) {
  try {
    PhantomSource::open(spec);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Phantom, SphereDistanceFieldFollowsTheDefinition) {
  auto p = PhantomSource::open("phantom:sphere?n=16,12,10&r=4&c=5,6,7");
  const VolumeInfo& info = p->info();
  EXPECT_EQ(info.dims, (std::array<std::int64_t, 3>{16, 12, 10}));
  EXPECT_EQ(info.type, VoxelType::kF32);
  EXPECT_EQ(info.suggestedIso, 960.0);
  ASSERT_TRUE(info.sphere.has_value());
  EXPECT_EQ(info.sphere->radius, 4.0);
  EXPECT_DOUBLE_EQ(p->value(5, 6, 7), 1000.0);
  EXPECT_DOUBLE_EQ(p->value(8, 10, 7), 950.0);  // distance 5
  std::vector<float> slice(16 * 12);
  int slices = 0;
  while (p->readSlice(slice)) ++slices;
  EXPECT_EQ(slices, 10);
  EXPECT_FLOAT_EQ(slice[0], static_cast<float>(1000 - 10 * std::sqrt(25 + 36 + 4)));
}

TEST(Phantom, BinaryFieldsAndDefaults) {
  auto s = PhantomSource::open("phantom:sphere?n=20&r=5&field=binary");
  EXPECT_EQ(s->info().type, VoxelType::kU8);
  EXPECT_EQ(s->info().suggestedIso, 50.0);
  // The default centre (9.5, 9.5, 9.5) is off the lattice.
  EXPECT_EQ(s->value(10, 10, 10), 100.0);
  EXPECT_EQ(s->value(9, 9, 14), 100.0);  // distance 4.53
  EXPECT_EQ(s->value(9, 9, 15), 0.0);    // distance 5.52
  auto b = PhantomSource::open("phantom:box?n=10&lo=2,2,2&hi=7,7,7");
  EXPECT_EQ(b->value(2, 7, 5), 100.0);
  EXPECT_EQ(b->value(1, 5, 5), 0.0);
  auto h = PhantomSource::open("phantom:head?n=32");
  EXPECT_EQ(h->info().type, VoxelType::kI16);
  EXPECT_NEAR(h->value(0, 0, 0), -1000, 150);
  auto t = PhantomSource::open("phantom:sphere?n=8&type=u16");
  EXPECT_EQ(t->info().type, VoxelType::kU16);
}

TEST(Phantom, NoiseIsDeterministicAndIndependentOfReadingOrder) {
  auto a = PhantomSource::open("phantom:head?n=24&seed=3");
  auto b = PhantomSource::open("phantom:head?n=24&seed=3");
  auto c = PhantomSource::open("phantom:head?n=24&seed=4");
  EXPECT_EQ(a->value(3, 4, 5), b->value(3, 4, 5));
  EXPECT_NE(a->value(3, 4, 5), c->value(3, 4, 5));
}

TEST(Phantom, BadSpecsNameTheProblem) {
  EXPECT_EQ(errorOf("phantom:blob"),
            "phantom:blob: unknown phantom 'blob' (known: sphere, box, torus, head, nested, boxes, checker, voxel, "
            "touch)");
  EXPECT_EQ(errorOf("phantom:sphere?q=1"),
            "phantom:sphere?q=1: unknown key 'q' for phantom 'sphere' (known: c, field, n, r, spacing, type)");
  EXPECT_EQ(errorOf("phantom:sphere?r=abc"),
            "phantom:sphere?r=abc: key 'r' has the value 'abc', which is not a number");
  EXPECT_EQ(errorOf("phantom:sphere?n=1"),
            "phantom:sphere?n=1: dims 1x1x1 are invalid: every axis needs at least 2 points");
  EXPECT_EQ(errorOf("phantom:sphere?type=q8"),
            "phantom:sphere?type=q8: unknown voxel type 'q8' (use u8 i8 u16 i16 u32 i32 f32 f64)");
  EXPECT_EQ(errorOf("phantom:sphere?n"), "phantom:sphere?n: 'n' is not key=value");
  EXPECT_EQ(errorOf("phantom:torus?R=5&r=6"), "phantom:torus?R=5&r=6: the minor radius r must be smaller than R");
}

}  // namespace
}  // namespace isoslab

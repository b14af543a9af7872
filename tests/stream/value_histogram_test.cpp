// The streamed histogram against counts made by brute force in the test, its passes and memory
// against the slice count, and Otsu's split against a plain search over every split.
#include "stream/value_histogram.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "core/error.h"
#include "io/open_source.h"
#include "stream/iso_choice.h"
#include "test_support.h"

namespace isoslab {
namespace {

using testing::VectorSource;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// Every value of the volume, and a source factory that counts the sources it made and the slices
// they handed out.
struct Volume {
  std::array<std::int64_t, 3> dims{};
  std::vector<float> values;
  std::optional<std::array<double, 2>> declaredRange;
  int opened = 0;

  std::unique_ptr<VectorSource> open() {
    ++opened;
    auto source = std::make_unique<VectorSource>(dims, values);
    source->mutableInfo().valueRange = declaredRange;
    return source;
  }
};

// The histogram's definition, counted the slow way: for every bin, the values v with
// lo + b * ((hi - lo) / n) <= v < the next edge (the last edge is hi, and the last bin holds it).
std::vector<std::uint64_t> bruteForceCounts(const std::vector<float>& values, double lo, double hi, std::size_t n) {
  std::vector<double> edges(n + 1);
  for (std::size_t b = 0; b < n; ++b) edges[b] = static_cast<double>(b) * ((hi - lo) / static_cast<double>(n)) + lo;
  edges[n] = hi;
  std::vector<std::uint64_t> counts(n, 0);
  for (std::size_t b = 0; b < n; ++b) {
    for (const float f : values) {
      const double v = f;
      if (v >= edges[b] && (v < edges[b + 1] || (b + 1 == n && v == hi))) ++counts[b];
    }
  }
  return counts;
}

ValueHistogram histogramOf(Volume& volume, std::size_t bins) {
  auto first = volume.open();
  return streamHistogram(*first, bins, [&] { return volume.open(); });
}

// Integers 0..100 (so that many fall exactly on the edges of 4 and 8 bins), NaN and infinities.
Volume fewValues(std::int64_t nz) {
  Volume v;
  v.dims = {7, 5, nz};
  std::mt19937 random(7);
  for (std::int64_t n = 0; n < 7 * 5 * nz; ++n) {
    const auto r = random() % 120;
    v.values.push_back(r == 101 ? kNaN : r == 102 ? kInf : r == 103 ? -kInf : static_cast<float>(r % 101));
  }
  return v;
}

// Floats from two normal modes (about 150,000 distinct values: more than kExactValues), NaN and
// infinities.
Volume manyValues(std::int64_t nz) {
  Volume v;
  v.dims = {64, 64, nz};
  std::mt19937 random(11);
  std::normal_distribution<float> air(-800.0F, 60.0F);
  std::normal_distribution<float> tissue(40.0F, 30.0F);
  for (std::int64_t n = 0; n < 64 * 64 * nz; ++n) {
    const auto r = random() % 1000;
    v.values.push_back(r == 0 ? kNaN : r == 1 ? kInf : r < 600 ? air(random) : tissue(random));
  }
  return v;
}

struct Expected {
  std::uint64_t nan = 0;
  std::uint64_t negativeInfinity = 0;
  std::uint64_t positiveInfinity = 0;
  double finiteLo = std::numeric_limits<double>::infinity();
  double finiteHi = -std::numeric_limits<double>::infinity();
};

Expected expected(const std::vector<float>& values) {
  Expected e;
  for (const float v : values) {
    if (std::isnan(v)) {
      ++e.nan;
    } else if (std::isinf(v)) {
      ++(v < 0 ? e.negativeInfinity : e.positiveInfinity);
    } else {
      e.finiteLo = std::min(e.finiteLo, static_cast<double>(v));
      e.finiteHi = std::max(e.finiteHi, static_cast<double>(v));
    }
  }
  return e;
}

void expectCounts(const ValueHistogram& h, const std::vector<float>& values) {
  const Expected e = expected(values);
  EXPECT_EQ(h.nan, e.nan);
  EXPECT_EQ(h.negativeInfinity, e.negativeInfinity);
  EXPECT_EQ(h.positiveInfinity, e.positiveInfinity);
  EXPECT_EQ(h.counts, bruteForceCounts(values, h.lo, h.hi, h.bins()));
  EXPECT_EQ(h.binned() + h.below + h.above + h.nan + h.negativeInfinity + h.positiveInfinity, values.size());
}

TEST(ValueHistogram, CountsAFewDistinctValuesExactlyInOnePass) {
  for (const std::size_t bins : {1u, 4u, 8u, 7u, 256u}) {
    Volume volume = fewValues(6);
    const ValueHistogram h = histogramOf(volume, bins);
    EXPECT_EQ(h.passes, 1);
    EXPECT_EQ(volume.opened, 1);
    EXPECT_FALSE(h.rangeFromReader);
    EXPECT_EQ(h.lo, 0.0);
    EXPECT_EQ(h.hi, 100.0);
    EXPECT_EQ(h.below + h.above, 0u);
    expectCounts(h, volume.values);
    ASSERT_TRUE(h.valueRange);
    EXPECT_EQ((*h.valueRange)[0], -std::numeric_limits<double>::infinity());
    EXPECT_EQ((*h.valueRange)[1], std::numeric_limits<double>::infinity());
    EXPECT_EQ(*h.finiteRange, (std::array<double, 2>{0.0, 100.0}));
  }
}

TEST(ValueHistogram, ManyDistinctValuesTakeASecondPass) {
  Volume volume = manyValues(40);
  const ValueHistogram h = histogramOf(volume, 256);
  EXPECT_EQ(h.passes, 2);
  EXPECT_EQ(volume.opened, 2);
  const Expected e = expected(volume.values);
  EXPECT_EQ(h.lo, e.finiteLo);
  EXPECT_EQ(h.hi, e.finiteHi);
  EXPECT_EQ(h.below + h.above, 0u);
  expectCounts(h, volume.values);
}

TEST(ValueHistogram, TakesTheReadersDeclaredRangeInOnePass) {
  Volume volume = manyValues(8);
  volume.declaredRange = std::array<double, 2>{-500.0, 500.0};
  const ValueHistogram h = histogramOf(volume, 100);
  EXPECT_TRUE(h.rangeFromReader);
  EXPECT_EQ(h.passes, 1);
  EXPECT_EQ(volume.opened, 1);
  EXPECT_EQ(h.lo, -500.0);
  EXPECT_EQ(h.hi, 500.0);
  expectCounts(h, volume.values);
  // A declared range that the data leave: the values outside are counted apart.
  std::uint64_t below = 0;
  std::uint64_t above = 0;
  for (const float v : volume.values) {
    if (std::isfinite(v) && v < -500) ++below;
    if (std::isfinite(v) && v > 500) ++above;
  }
  EXPECT_GT(below, 0u);
  EXPECT_EQ(h.below, below);
  EXPECT_EQ(h.above, above);
}

TEST(ValueHistogram, PassesAndMemoryDoNotDependOnTheSliceCount) {
  for (const bool many : {false, true}) {
    std::optional<ValueHistogram> previous;
    for (const std::int64_t nz : {3, 30, 300}) {
      Volume volume = many ? manyValues(nz) : fewValues(nz);
      if (many && nz < 30) continue;  // 3 slices hold fewer than kExactValues values
      const ValueHistogram h = histogramOf(volume, 256);
      EXPECT_EQ(h.slicesRead, h.passes * nz) << nz;
      EXPECT_EQ(volume.opened, h.passes) << nz;
      if (previous) {
        EXPECT_EQ(h.passes, previous->passes) << nz;
        EXPECT_EQ(h.workingBytes, previous->workingBytes) << nz;
      }
      previous = h;
    }
    EXPECT_EQ(previous->passes, many ? 2 : 1);
    EXPECT_LE(previous->workingBytes, std::size_t{2} << 20);
  }
}

TEST(ValueHistogram, OneValueAndNoFiniteValue) {
  Volume constant{{4, 4, 3}, std::vector<float>(48, 5.0F), std::nullopt};
  constant.values[3] = kNaN;
  const ValueHistogram h = histogramOf(constant, 10);
  EXPECT_EQ(h.lo, 4.5);  // numpy widens a single value by 0.5 each way
  EXPECT_EQ(h.hi, 5.5);
  expectCounts(h, constant.values);
  EXPECT_EQ(h.counts[5], 47u);
  EXPECT_FALSE(otsuSplit(h));

  Volume nan{{4, 4, 3}, std::vector<float>(48, kNaN), std::nullopt};
  const ValueHistogram none = histogramOf(nan, 10);
  EXPECT_EQ(none.nan, 48u);
  EXPECT_EQ(none.binned(), 0u);
  EXPECT_FALSE(none.valueRange);
  EXPECT_FALSE(none.finiteRange);
  EXPECT_FALSE(otsuSplit(none));
}

// Otsu's criterion written plainly: for every split, the class probabilities and means from their
// own sums (in long double), the between-class variance p0 p1 (m0 - m1)^2.
struct BruteOtsu {
  std::size_t k = 0;
  long double best = -1;
};

BruteOtsu bruteForceOtsu(const ValueHistogram& h) {
  BruteOtsu result;
  const long double total = static_cast<long double>(h.binned());
  for (std::size_t k = 1; k < h.bins(); ++k) {
    long double w0 = 0, w1 = 0, s0 = 0, s1 = 0;
    for (std::size_t b = 0; b < h.bins(); ++b) {
      const long double c = static_cast<long double>(h.counts[b]);
      const long double x = (static_cast<long double>(h.edge(b)) + static_cast<long double>(h.edge(b + 1))) / 2;
      (b < k ? w0 : w1) += c;
      (b < k ? s0 : s1) += c * x;
    }
    if (w0 == 0 || w1 == 0) continue;
    const long double d = s0 / w0 - s1 / w1;
    const long double variance = (w0 / total) * (w1 / total) * d * d;
    if (variance > result.best) result = {k, variance};
  }
  return result;
}

TEST(Otsu, AgreesWithAPlainSearchOverEverySplit) {
  std::mt19937 random(3);
  int compared = 0;
  for (int trial = 0; trial < 200; ++trial) {
    ValueHistogram h;
    h.lo = -1000.0 + static_cast<double>(random() % 100);
    h.hi = h.lo + 1.0 + static_cast<double>(random() % 3000);
    h.counts.resize(2 + random() % 300);
    // Two bumps of random heights and widths over a floor, with some bins empty.
    const double a = static_cast<double>(random() % h.counts.size());
    const double b = static_cast<double>(random() % h.counts.size());
    for (std::size_t n = 0; n < h.counts.size(); ++n) {
      const double x = static_cast<double>(n);
      const double height = 1e4 * std::exp(-(x - a) * (x - a) / 50) + 3e3 * std::exp(-(x - b) * (x - b) / 200);
      h.counts[n] = random() % 5 == 0 ? 0 : static_cast<std::uint64_t>(height) + random() % 20;
    }
    const auto split = otsuSplit(h);
    const BruteOtsu brute = bruteForceOtsu(h);
    ASSERT_EQ(split.has_value(), brute.k > 0);
    if (!split) continue;
    ++compared;
    // Splits separated by empty bins tie exactly; otherwise a near-tie may go either way.
    std::size_t k = brute.k;
    while (k > 1 && h.counts[k - 1] == 0) --k;
    if (split->firstUpperBin != k) {
      const auto total = static_cast<double>(h.binned());
      EXPECT_NEAR(split->score / (total * total), static_cast<double>(brute.best),
                  1e-12 * static_cast<double>(brute.best))
          << trial;
      continue;
    }
    EXPECT_GT(h.counts[k - 1], 0u);
    std::size_t occupied = k;
    while (h.counts[occupied] == 0) ++occupied;
    EXPECT_EQ(split->firstOccupied, occupied);
    EXPECT_EQ(split->iso, occupied == k ? h.edge(k) : (h.edge(k) + h.edge(occupied)) / 2);
  }
  EXPECT_GT(compared, 150);
}

TEST(Otsu, SeparatesTheModesOfABinarySphereAndTheHeadPhantom) {
  // The binary sphere: 0 and 100, so the split is anywhere between; the iso value is the middle.
  auto sphere = openSource("phantom:sphere?n=32&r=9&field=binary", {});
  ValueHistogram h = streamHistogram(*sphere, 256, [] { return nullptr; });
  auto split = otsuSplit(h);
  ASSERT_TRUE(split);
  EXPECT_EQ(split->firstUpperBin, 1u);
  EXPECT_EQ(split->firstOccupied, 255u);
  EXPECT_EQ(split->iso, 50.0);
  EXPECT_EQ(h.counts[0] + h.counts[255], 32u * 32 * 32);

  // The head phantom: air about -1000 against soft tissue about 40 (and bone about 700).
  auto head = openSource("phantom:head?n=64", {});
  h = streamHistogram(*head, 256, [] { return openSource("phantom:head?n=64", {}); });
  EXPECT_EQ(h.passes, 1);  // 16-bit: few distinct values
  split = otsuSplit(h);
  ASSERT_TRUE(split);
  EXPECT_GT(split->iso, -900.0);
  EXPECT_LT(split->iso, -100.0);
}

TEST(IsoChoice, ParsesNumbersAutoAndNames) {
  EXPECT_EQ(parseIsoRequest("90.5")->value, 90.5);
  EXPECT_EQ(parseIsoRequest("-400")->kind, IsoRequest::Kind::kValue);
  EXPECT_EQ(parseIsoRequest("AUTO")->kind, IsoRequest::Kind::kAuto);
  EXPECT_EQ(parseIsoRequest("Bone")->named.hounsfield, 300.0);
  EXPECT_EQ(parseIsoRequest("skin")->named.hounsfield, -400.0);
  for (const char* bad : {"", "nan", "inf", "-inf", "1e400", "bones", "90.5x", "auto2"}) {
    EXPECT_FALSE(parseIsoRequest(bad)) << bad;
  }
}

TEST(IsoChoice, NamesAreForCtAndInputsThatNameNoModality) {
  VectorSource source({2, 2, 2}, std::vector<float>(8, 0.0F));
  const SourceOpener none = [] { return nullptr; };
  IsoRequest skin = *parseIsoRequest("skin");
  source.mutableInfo().modality = "CT";
  IsoChoice c = chooseIso(skin, "in", source, none);
  EXPECT_EQ(c.value, -400.0);
  EXPECT_EQ(c.source, "skin (-400 HU)");
  EXPECT_EQ(c.note, "`iso` skin: -400 HU (the input is CT)");
  EXPECT_FALSE(c.sourceRead);
  source.mutableInfo().modality = "";
  c = chooseIso(skin, "in", source, none);
  EXPECT_EQ(c.value, -400.0);
  EXPECT_EQ(c.note, "`iso` skin: -400, taken as Hounsfield units (the input names no modality)");
  source.mutableInfo().modality = "MR";
  try {
    chooseIso(*parseIsoRequest("bone"), "in", source, none);
    FAIL() << "MR accepted";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "in: `iso` bone means 300 HU, a CT value, but the input's modality is MR; give the iso value as a "
                 "number");
  }
  EXPECT_EQ(source.slicesRead(), 0);
}

TEST(IsoChoice, AutoReadsTheSourceAndRefusesAVolumeOfOneValue) {
  Volume volume = fewValues(4);
  auto source = volume.open();
  const IsoChoice c = chooseIso(*parseIsoRequest("auto"), "in", *source, [&] { return volume.open(); });
  EXPECT_TRUE(c.sourceRead);
  ASSERT_TRUE(c.split && c.histogram);
  EXPECT_EQ(c.value, c.split->iso);
  EXPECT_EQ(c.source, "auto (Otsu, 256 bins)");
  EXPECT_EQ(c.note.rfind("`iso` auto: Otsu threshold ", 0), 0u) << c.note;

  VectorSource constant({4, 4, 2}, std::vector<float>(32, 7.0F));
  try {
    chooseIso(*parseIsoRequest("auto"), "in", constant, [] { return nullptr; });
    FAIL() << "a constant volume got a threshold";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "in: `iso` auto: no threshold separates the values: every finite value is 7");
  }
}

}  // namespace
}  // namespace isoslab

// Otsu's threshold: N. Otsu, "A threshold selection method from gray-level histograms", IEEE
// Transactions on Systems, Man and Cybernetics 9(1), 62-66, 1979.
#include "stream/value_histogram.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "core/error.h"
#include "core/interrupt.h"

namespace isoslab {

double ValueHistogram::edge(std::size_t b) const noexcept {
  // numpy.linspace(lo, hi, bins + 1): arange * step + start, and the last edge exactly hi.
  if (b >= counts.size()) return hi;
  return static_cast<double>(b) * ((hi - lo) / static_cast<double>(counts.size())) + lo;
}

double ValueHistogram::centre(std::size_t b) const noexcept {
  return (edge(b) + edge(b + 1)) / 2.0;
}

std::size_t ValueHistogram::binOf(double value) const noexcept {
  // numpy.histogram's uniform-bin search: a first guess from the value, corrected by the edges.
  const std::size_t n = counts.size();
  const double f = (value - lo) / (hi - lo) * static_cast<double>(n);
  std::size_t b = f <= 0 ? 0 : std::min(static_cast<std::size_t>(f), n - 1);
  if (b > 0 && value < edge(b)) {
    --b;
  } else if (b + 1 < n && value >= edge(b + 1)) {
    ++b;
  }
  return b;
}

std::uint64_t ValueHistogram::binned() const noexcept {
  std::uint64_t total = 0;
  for (const std::uint64_t c : counts) total += c;
  return total;
}

namespace {

// Exact counts of up to kExactValues distinct finite floats: open addressing on the value's bits
// (-0 is stored as +0), at most half full. Once a value would exceed the limit the table gives up
// (`overflowed`) and forgets its counts.
class DistinctValues {
 public:
  static constexpr std::size_t kSlots = 2 * kExactValues;
  static constexpr std::uint32_t kEmpty = 0xFFFFFFFFu;  // a NaN's bits, never a key

  DistinctValues() : keys_(kSlots, kEmpty), counts_(kSlots, 0) {}

  bool overflowed() const noexcept { return overflowed_; }
  std::size_t bytes() const noexcept { return kSlots * (sizeof(std::uint32_t) + sizeof(std::uint64_t)); }

  void add(float value) noexcept {
    const std::uint32_t key = std::bit_cast<std::uint32_t>(value == 0.0F ? 0.0F : value);
    if (key == lastKey_) {
      ++counts_[lastSlot_];
      return;
    }
    std::size_t slot = (key * 0x9E3779B1u) >> (32 - kBits);
    while (keys_[slot] != key) {
      if (keys_[slot] == kEmpty) {
        if (size_ == kExactValues) {
          overflowed_ = true;
          return;
        }
        keys_[slot] = key;
        ++size_;
        break;
      }
      slot = (slot + 1) & (kSlots - 1);
    }
    ++counts_[slot];
    lastKey_ = key;
    lastSlot_ = slot;
  }

  /// Calls f(value, count) for every value held.
  template <typename F>
  void forEach(F&& f) const {
    for (std::size_t s = 0; s < kSlots; ++s) {
      if (keys_[s] != kEmpty) f(std::bit_cast<float>(keys_[s]), counts_[s]);
    }
  }

  void release() {
    keys_ = {};
    counts_ = {};
  }

 private:
  static constexpr int kBits = std::countr_zero(kSlots);
  std::vector<std::uint32_t> keys_;
  std::vector<std::uint64_t> counts_;
  std::size_t size_ = 0;
  std::uint32_t lastKey_ = kEmpty;
  std::size_t lastSlot_ = 0;
  bool overflowed_ = false;
};

// The range [lo, hi] of the bins from the extreme finite values, as numpy.histogram widens a
// single value.
void setRange(ValueHistogram& h, double lo, double hi) {
  if (!(lo <= hi)) {
    lo = 0;
    hi = 1;
  } else if (lo == hi) {
    lo -= 0.5;
    hi += 0.5;
  }
  h.lo = lo;
  h.hi = hi;
}

// Tracks what every pass that meets a value for the first time must: NaN and infinities apart, and
// the range of the values that are not NaN.
struct FirstPassCounts {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  double finiteLo = std::numeric_limits<double>::infinity();
  double finiteHi = -std::numeric_limits<double>::infinity();

  // Returns whether `v` is finite.
  bool add(ValueHistogram& h, float v) noexcept {
    if (std::isnan(v)) {
      ++h.nan;
      return false;
    }
    const double d = v;
    lo = std::min(lo, d);
    hi = std::max(hi, d);
    if (std::isinf(v)) {
      ++(v < 0 ? h.negativeInfinity : h.positiveInfinity);
      return false;
    }
    finiteLo = std::min(finiteLo, d);
    finiteHi = std::max(finiteHi, d);
    return true;
  }

  void finish(ValueHistogram& h) const {
    if (lo <= hi) h.valueRange = std::array<double, 2>{lo, hi};
    if (finiteLo <= finiteHi) h.finiteRange = std::array<double, 2>{finiteLo, finiteHi};
  }
};

void binValue(ValueHistogram& h, double v, std::uint64_t count) noexcept {
  if (v < h.lo) {
    h.below += count;
  } else if (v > h.hi) {
    h.above += count;
  } else {
    h.counts[h.binOf(v)] += count;
  }
}

}  // namespace

ValueHistogram streamHistogram(SliceSource& source, std::size_t bins, const SourceOpener& reopen) {
  ValueHistogram h;
  h.counts.assign(std::max<std::size_t>(bins, 1), 0);
  h.workingBytes = h.counts.size() * sizeof(std::uint64_t);
  const VolumeInfo& info = source.info();
  std::vector<float> slice;  // sized by readSliceInto once the first slice's data is there
  FirstPassCounts first;

  // PASS 1 with a declared range: bin as the slices stream past.
  const auto& declared = info.valueRange;
  if (declared && std::isfinite((*declared)[0]) && std::isfinite((*declared)[1]) && (*declared)[0] <= (*declared)[1]) {
    setRange(h, (*declared)[0], (*declared)[1]);
    h.rangeFromReader = true;
    h.passes = 1;
    for (; readSliceInto(source, slice); ++h.slicesRead) {
      throwIfInterrupted();
      for (const float v : slice) {
        if (first.add(h, v)) binValue(h, v, 1);
      }
    }
    first.finish(h);
    return h;
  }

  // PASS 1 without one: the range, NaN and infinities, and the exact counts while the distinct
  // finite values are few.
  DistinctValues exact;
  h.workingBytes += exact.bytes();
  h.passes = 1;
  for (; readSliceInto(source, slice); ++h.slicesRead) {
    throwIfInterrupted();
    for (const float v : slice) {
      if (first.add(h, v) && !exact.overflowed()) exact.add(v);
    }
  }
  first.finish(h);
  setRange(h, first.finiteLo, first.finiteHi);
  if (!exact.overflowed()) {
    exact.forEach([&](float v, std::uint64_t count) { binValue(h, v, count); });
    return h;
  }
  exact.release();

  // PASS 2: bin every finite value of a fresh source. NaN and infinities were counted in pass 1.
  auto again = reopen();
  if (!again || again->info().dims != info.dims) {
    throw Error(info.source + ": the second pass over the input found other dims than the first");
  }
  h.passes = 2;
  for (; readSliceInto(*again, slice); ++h.slicesRead) {
    throwIfInterrupted();
    for (const float v : slice) {
      if (std::isfinite(v)) binValue(h, v, 1);
    }
  }
  return h;
}

std::optional<OtsuSplit> otsuSplit(const ValueHistogram& histogram) {
  const std::vector<std::uint64_t>& counts = histogram.counts;
  const std::size_t n = counts.size();
  if (std::count_if(counts.begin(), counts.end(), [](std::uint64_t c) { return c > 0; }) < 2) return std::nullopt;
  // scikit-image's order of operations: the class weights and first moments as cumulative sums from
  // each end, in double, the moments of the bin centres; variance12 = w0 * w1 * (m0 - m1)^2.
  std::vector<double> centres(n);
  for (std::size_t b = 0; b < n; ++b) centres[b] = histogram.centre(b);
  std::vector<double> upperMean(n);  // mean of bins b .. n - 1
  std::vector<std::uint64_t> upperWeight(n);
  {
    std::uint64_t w = 0;
    double moment = 0;
    for (std::size_t b = n; b-- > 0;) {
      w += counts[b];
      moment += static_cast<double>(counts[b]) * centres[b];
      upperWeight[b] = w;
      upperMean[b] = moment / static_cast<double>(w);
    }
  }
  std::optional<OtsuSplit> best;
  std::uint64_t w0 = 0;
  double moment0 = 0;
  for (std::size_t k = 1; k < n; ++k) {
    w0 += counts[k - 1];
    moment0 += static_cast<double>(counts[k - 1]) * centres[k - 1];
    const std::uint64_t w1 = upperWeight[k];
    if (w0 == 0 || w1 == 0) continue;
    const double difference = moment0 / static_cast<double>(w0) - upperMean[k];
    const double score = static_cast<double>(w0) * static_cast<double>(w1) * (difference * difference);
    if (!best || score > best->score) best = OtsuSplit{k, k, 0, score};
  }
  if (!best) return std::nullopt;
  // Splits inside a run of empty bins tie and put every value in the same class; the iso value
  // goes to the middle of the run, as far as it can be from both classes' values.
  while (counts[best->firstOccupied] == 0) ++best->firstOccupied;
  best->iso = best->firstOccupied == best->firstUpperBin
                  ? histogram.edge(best->firstUpperBin)
                  : (histogram.edge(best->firstUpperBin) + histogram.edge(best->firstOccupied)) / 2.0;
  return best;
}

}  // namespace isoslab

// A histogram of a volume's values, streamed from its source one slice at a time, and Otsu's
// threshold on it. Memory is one slice, the bins and a table of at most kExactValues distinct
// values, whatever the number of slices.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>

#include "io/slice_source.h"

namespace isoslab {

/// Opens a fresh source of the same volume, for another pass over it (sources cannot rewind).
using SourceOpener = std::function<std::unique_ptr<SliceSource>()>;

/// The counts of a volume's values in equal bins over [lo, hi].
///
/// Bin b holds the values v with edge(b) <= v < edge(b + 1), and the last bin also holds hi. The
/// edges are b * ((hi - lo) / bins) + lo, and edge(bins) is hi: numpy.histogram's edges and bins
/// with range=(lo, hi), so scikit-image sees the same histogram. NaN and infinite values are counted
/// apart and never binned. Finite values outside [lo, hi] can only occur when a reader declares a
/// range that its data leave (a bug); they are counted as `below` and `above`.
struct ValueHistogram {
  double lo = 0;
  double hi = 1;
  std::vector<std::uint64_t> counts;
  std::uint64_t nan = 0;
  std::uint64_t negativeInfinity = 0;
  std::uint64_t positiveInfinity = 0;
  std::uint64_t below = 0;
  std::uint64_t above = 0;
  /// The smallest and largest value that is not NaN (infinities included); empty when every value
  /// is NaN.
  std::optional<std::array<double, 2>> valueRange;
  /// The smallest and largest finite value; empty when there is none.
  std::optional<std::array<double, 2>> finiteRange;
  /// Whether [lo, hi] is the reader's declared range (VolumeInfo::valueRange) rather than the range
  /// of the finite values read.
  bool rangeFromReader = false;
  /// Passes over the volume: 1, or 2 when the range had to be found first and the volume holds more
  /// than kExactValues distinct finite values.
  int passes = 0;
  /// Slices read, over every pass.
  std::int64_t slicesRead = 0;
  /// Working memory besides the slice buffer: the bins and the distinct-value table.
  std::size_t workingBytes = 0;

  std::size_t bins() const noexcept { return counts.size(); }
  double edge(std::size_t b) const noexcept;
  /// (edge(b) + edge(b + 1)) / 2, as scikit-image's bin centres.
  double centre(std::size_t b) const noexcept;
  /// The bin of a finite value in [lo, hi].
  std::size_t binOf(double value) const noexcept;
  /// Finite values in the bins.
  std::uint64_t binned() const noexcept;
};

/// The most distinct finite values whose exact counts the first pass keeps; every 8- and 16-bit
/// volume (rescaled or not) has at most 65,536.
inline constexpr std::size_t kExactValues = std::size_t{1} << 16;

/// Counts the values of `source` in `bins` bins (bins >= 1), reading it to its end.
///
/// The range is the reader's declared VolumeInfo::valueRange when it has one (one pass).
/// Otherwise the first pass finds the finite values' range, and while the volume holds at most
/// kExactValues distinct finite values it also keeps their exact counts, from which the bins follow
/// (one pass). With more distinct values, `reopen` gives a fresh source for a second pass that
/// bins. A single finite value v gets the range v - 0.5 .. v + 0.5, as numpy's; no finite value at
/// all gives 0 .. 1 and empty bins. Throws isoslab::Error from the sources, and Interrupted
/// between slices.
ValueHistogram streamHistogram(SliceSource& source, std::size_t bins, const SourceOpener& reopen);

/// Otsu's split of a histogram into a lower and an upper class.
struct OtsuSplit {
  /// The upper class's first bin k: bins 0 .. k - 1 are the lower class (outside), k .. bins - 1
  /// the upper one (inside).
  std::size_t firstUpperBin = 0;
  /// The first non-empty bin at or above k: bins k .. firstOccupied - 1 are empty.
  std::size_t firstOccupied = 0;
  /// The iso value: the middle of the empty bins between the classes, (edge(k) +
  /// edge(firstOccupied)) / 2, which is edge(k), the upper edge of the last lower bin, when bin k
  /// holds values. Every binned value >= iso lies in the upper class, every one below in the
  /// lower, so "value >= iso is inside" keeps the split exactly.
  double iso = 0;
  /// The between-class variance w0 w1 (m0 - m1)^2 of the split (counts, not fractions).
  double score = 0;
};

/// Otsu's threshold (N. Otsu, "A threshold selection method from gray-level histograms", IEEE
/// Trans. Systems, Man and Cybernetics 9(1), 1979): the split k that maximises the between-class
/// variance, the bins taken at their centres, the first k when several tie. This is
/// skimage.filters.threshold_otsu with hist=(counts, centres), computed in the same order, whose
/// threshold is centre(k - 1) with "value > threshold" as the foreground. Splits that leave a class
/// empty are skipped. Empty when fewer than two bins hold values.
std::optional<OtsuSplit> otsuSplit(const ValueHistogram& histogram);

}  // namespace isoslab

// The seam between readers and the rest of isoslab: a volume's geometry up front, then its slices
// one at a time, in order, each converted once to float.
//
// A SliceSource never holds the whole volume. Readers are opened by factories (openSource(),
// RawReader::open(), PhantomSource::open()) that throw isoslab::Error with a message naming the
// file and the problem; readSlice() reports truncated or unreadable data the same way.
// A SliceSource is used from one thread at a time.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "io/voxel_type.h"

namespace isoslab {

/// A sphere known analytically, in voxel (lattice) coordinates; phantoms describe themselves with
/// it so that precision metrics can be computed against the truth.
struct AnalyticSphere {
  std::array<double, 3> centre{};
  double radius = 0;
};

/// Geometry and type of a volume, known before any slice is read.
///
/// Lattice point (i, j, k) lies at  origin + direction * (i*sx, j*sy, k*sz)  in the source's
/// physical frame (millimetres for scanner data). `direction` is row-major and its columns are the
/// unit directions of the i, j and k axes. When `sliceOrigins` is not empty it holds the physical
/// position of lattice point (0, 0, k) for every slice k, and overrides origin + k*sz*dir_k (this is
/// how uneven slice spacing and gantry tilt are represented).
struct VolumeInfo {
  std::array<std::int64_t, 3> dims{};
  std::array<double, 3> spacing{1.0, 1.0, 1.0};
  std::array<double, 3> origin{0.0, 0.0, 0.0};
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::vector<std::array<double, 3>> sliceOrigins;
  VoxelType type = VoxelType::kU8;
  /// Smallest and largest value, where the reader knows them without reading the data.
  std::optional<std::array<double, 2>> valueRange;
  /// An iso value the source suggests (phantoms do), used when the user gives none.
  std::optional<double> suggestedIso;
  /// The analytic surface at suggestedIso, where there is one.
  std::optional<AnalyticSphere> sphere;
  /// The physical frame the coordinates are in: "physical" (unspecified), or "lps" (DICOM patient
  /// coordinates, millimetres).
  std::string frame = "physical";
  /// Which reader made this source ("raw", "phantom", "dicom", ...) and what it read.
  std::string reader;
  std::string source;
  /// The imaging modality where the input names it (DICOM's Modality: "CT", "MR", ...), else empty.
  std::string modality;

  std::int64_t sliceVoxels() const noexcept { return dims[0] * dims[1]; }
};

class SliceSource {
 public:
  virtual ~SliceSource() = default;
  SliceSource() = default;
  SliceSource(const SliceSource&) = delete;
  SliceSource& operator=(const SliceSource&) = delete;

  virtual const VolumeInfo& info() const noexcept = 0;

  /// Reads the next slice into `slice`, which the caller owns and which must hold exactly
  /// info().sliceVoxels() values, x fastest. Returns false, leaving `slice` untouched, once all
  /// info().dims[2] slices have been read. Throws isoslab::Error if the data is short or unreadable.
  virtual bool readSlice(std::span<float> slice) = 0;

  /// Whether the source holds its slices in memory as float and can lend them (lendSlice)
  /// instead of copying them, as a volume already in memory can.
  virtual bool lendsSlices() const noexcept { return false; }

  /// The next slice's values, x fastest, valid as long as the source lives; nullptr once all
  /// slices have been handed out. Only for sources that lend slices.
  virtual const float* lendSlice() { return nullptr; }

  /// Problems with the data that are not errors, one line each without a prefix, for the user
  /// (for example bytes left over after the last slice, which suggest wrong dims or type). Call it
  /// after reading every slice: a reader may then read what is left of a compressed stream to
  /// count it. Empty for most sources.
  virtual std::vector<std::string> warnings() { return {}; }
};

/// Checks dims for sanity (every axis at least 2 and at most 2^31-1 points, the product
/// representable); throws isoslab::Error mentioning `what` otherwise.
void validateDims(const std::array<std::int64_t, 3>& dims, const std::string& what);

/// Checks a volume's geometry, whatever read it: every spacing finite and positive, the origin and
/// every slice origin finite, the direction's entries finite, no column zero, and the columns
/// neither collinear nor nearly coplanar (a flat or NaN mesh would follow). Throws
/// isoslab::Error "WHAT: FIELD ..." naming the field otherwise. openSource() applies it to every
/// source it opens.
void validateGeometry(const VolumeInfo& info, const std::string& what);

}  // namespace isoslab

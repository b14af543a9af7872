// The geometry and type of a volume, known before any of its slices is read.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/voxel_type.h"

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
  /// The input says it holds labels (NIfTI's NIFTI_INTENT_LABEL, label phantoms): extract takes
  /// --labels all when neither --iso nor --labels is given.
  bool labelMap = false;
  /// Labels that the file names (3D Slicer's .seg.nrrd): value, name, sRGB colour, layer.
  struct Label {
    std::int32_t value = 0;
    std::string name;
    std::optional<std::array<std::uint8_t, 3>> color;
    int layer = 0;
  };
  std::vector<Label> labels;
  /// Planes per slice: a segmentation read with every layer at once (kEveryLayer) hands out each
  /// slice as `layers` planes of dims[0] x dims[1] values one after another, layer 0 first, each
  /// holding that layer's label values. Every other source has one.
  int layers = 1;
  /// The analytic surface at suggestedIso, where there is one.
  std::optional<AnalyticSphere> sphere;
  /// The physical frame the coordinates are in: "physical" (unspecified), or "lps" (DICOM patient
  /// coordinates, millimetres).
  std::string frame = "physical";
  /// Which reader made this source ("raw", "phantom", "dicom", ...) and what it read.
  std::string reader;
  std::string source;
  /// The input's own names for where spacing (per axis) and origin came from, for messages that
  /// refuse a geometry: "pixdim", "NRRD space directions", "PixelSpacing", "--spacing", ...
  std::array<std::string, 3> spacingFields{"spacing", "spacing", "spacing"};
  std::string originField = "origin";
  /// The imaging modality where the input names it (DICOM's Modality: "CT", "MR", ...), else empty.
  std::string modality;

  std::int64_t sliceVoxels() const noexcept { return dims[0] * dims[1]; }
  /// The values of one slice as readSlice() hands it out: its voxels times its layers.
  std::int64_t sliceValues() const noexcept { return sliceVoxels() * layers; }
};

/// The most layers read in one pass (every label key then fits in 32 bits).
constexpr int kMaxLayers = 31;

/// The largest label magnitude: slices are float, whose integers are exact up to 2^24, and every
/// integer of a larger magnitude is read as one of 2^24 or more (2^24 + 1 as 2^24), so 2^24 itself
/// is out too: a file's labels 2^24 and 2^24 + 1 would be read as one.
constexpr double kLargestLabel = 16777215.0;

/// A label of a layered segmentation as one number, unique over the layers: its value (within
/// +-kLargestLabel) plus its layer times 2^26. Layer 0's labels keep their values.
constexpr std::int32_t layeredLabel(int layer, std::int32_t value) noexcept {
  return value + layer * (1 << 26);
}
/// The layer and the value of a layeredLabel().
constexpr int labelLayer(std::int32_t key) noexcept {
  return (key + (1 << 25)) >> 26;
}
constexpr std::int32_t labelValue(std::int32_t key) noexcept {
  return key - labelLayer(key) * (1 << 26);
}

/// A box of lattice points given by index, inclusive on both ends (as vtkExtractVOI's VOI): points
/// lo[a] .. hi[a] on axis a, hi[a] - lo[a] + 1 of them.
struct LatticeBox {
  std::array<std::int64_t, 3> lo{};
  std::array<std::int64_t, 3> hi{};

  std::array<std::int64_t, 3> dims() const noexcept {
    return {hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1};
  }
  bool operator==(const LatticeBox&) const = default;
};

/// Checks dims for sanity (every axis at least 2 and at most 2^31-1 points, the product
/// representable); throws isoslab::Error mentioning `what` otherwise.
void validateDims(const std::array<std::int64_t, 3>& dims, const std::string& what);

}  // namespace isoslab

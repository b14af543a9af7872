// The map from lattice coordinates (i, j, k), in voxel units, to output coordinates.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh_sink.h"
#include "core/vec3.h"
#include "core/volume_info.h"

namespace isoslab {

class LatticeFrame {
 public:
  /// Output coordinates are the lattice coordinates themselves.
  static LatticeFrame voxel();
  /// Output coordinates are the source's physical frame: origin + direction * spacing, or the
  /// per-slice origins when the source has them.
  static LatticeFrame physical(const VolumeInfo& info);

  /// The frame named by --space: "voxel"; "physical" (the source's frame); "lps" or "ras", which
  /// take the source's frame as LPS (DICOM's patient frame) and, for "ras", negate x and y.
  /// Throws isoslab::Error for another name.
  static LatticeFrame forSpace(const VolumeInfo& info, const std::string& space);

  /// Position of lattice point (i, j, k); k may be fractional between slices. The affine case is
  /// inline: extraction maps every vertex.
  Vec3d map(double i, double j, double k) const noexcept {
    if (!sliceOrigins_.empty()) return mapPerSlice(i, j, k);
    const auto& m = linear_;
    return {origin_[0] + m[0] * i + m[1] * j + m[2] * k, origin_[1] + m[3] * i + m[4] * j + m[5] * k,
            origin_[2] + m[6] * i + m[7] * j + m[8] * k};
  }

  /// map() along one row of the lattice (j and k fixed): the same sums in the same order, so the
  /// same bits, with the row's own terms computed once.
  class Row {
   public:
    Row(const LatticeFrame& frame, double j, double k) noexcept
        : frame_(&frame), j_(j), k_(k), affine_(frame.sliceOrigins_.empty()) {
      const auto& m = frame.linear_;
      for (std::size_t a = 0; a < 3; ++a) {
        origin_[a] = frame.origin_[a];
        step_[a] = m[3 * a];
        jTerm_[a] = m[3 * a + 1] * j;
        kTerm_[a] = m[3 * a + 2] * k;
      }
    }
    Vec3d at(double i) const noexcept {
      if (!affine_) return frame_->map(i, j_, k_);
      return {origin_[0] + step_[0] * i + jTerm_[0] + kTerm_[0], origin_[1] + step_[1] * i + jTerm_[1] + kTerm_[1],
              origin_[2] + step_[2] * i + jTerm_[2] + kTerm_[2]};
    }

   private:
    const LatticeFrame* frame_;
    double j_, k_;
    bool affine_;
    std::array<double, 3> origin_{}, step_{}, jTerm_{}, kTerm_{};
  };

  /// Converts a gradient taken with respect to lattice coordinates into one with respect to output
  /// coordinates (multiplies by the inverse transpose of the linear part). Inline: extraction
  /// converts every vertex's normal.
  Vec3d gradient(const Vec3d& g) const noexcept {
    const auto& m = inverseT_;
    return {m[0] * g[0] + m[1] * g[1] + m[2] * g[2], m[3] * g[0] + m[4] * g[1] + m[5] * g[2],
            m[6] * g[0] + m[7] * g[1] + m[8] * g[2]};
  }

  /// True if the frame is left-handed, so that triangle winding must be reversed to keep normals
  /// pointing from high to low values.
  bool flipsWinding() const noexcept { return determinant_ < 0; }

  /// The box around the lattice's eight corners in output coordinates: xmin ymin zmin xmax ymax zmax.
  /// `margin` moves each corner that many lattice steps out along every axis (0.5: the voxels'
  /// boxes, where the label complex's caps lie).
  std::array<double, 6> bounds(const std::array<std::int64_t, 3>& dims, double margin = 0) const noexcept;

  /// The lattice's six faces as planes (MeshHeader::volumeFaces), or nothing when the slices'
  /// origins bend a face out of its plane by more than a rounding tolerance.
  /// `margin` as for bounds().
  std::optional<VolumeFaces> faces(const std::array<std::int64_t, 3>& dims, double margin = 0) const;

  /// The smallest box of lattice indices (of a lattice of `dims`) that holds every lattice point
  /// whose position, as map() gives it, lies in the axis-aligned `box` (xmin ymin zmin xmax ymax
  /// zmax, both ends inclusive); nothing when no lattice point does. Exact for every frame, tilted
  /// and per-slice origins too: each row of the lattice is cut by the box's six planes, and the
  /// ends of the cut are checked with map() itself. Costs a few map()s per row (dims[1] * dims[2]).
  std::optional<LatticeBox> latticeBox(const std::array<double, 6>& box,
                                       const std::array<std::int64_t, 3>& dims) const noexcept;

  /// Output volume of one unit lattice cube.
  double cellVolume() const noexcept { return determinant_ < 0 ? -determinant_ : determinant_; }
  /// The shortest lattice step in output units: the shortest column of the linear map.
  double smallestEdge() const noexcept {
    double best = 0;
    for (std::size_t a = 0; a < 3; ++a) {
      const double x = linear_[a], y = linear_[3 + a], z = linear_[6 + a];
      const double length = std::sqrt(x * x + y * y + z * z);
      best = a == 0 ? length : std::min(best, length);
    }
    return best;
  }

  const std::string& name() const noexcept { return name_; }

 private:
  Vec3d mapPerSlice(double i, double j, double k) const noexcept;

  std::string name_ = "voxel";
  Vec3d origin_{0, 0, 0};
  std::array<double, 9> linear_{1, 0, 0, 0, 1, 0, 0, 0, 1};    // row-major, columns per axis
  std::array<double, 9> inverseT_{1, 0, 0, 0, 1, 0, 0, 0, 1};  // inverse transpose of linear_
  std::vector<Vec3d> sliceOrigins_;
  double determinant_ = 1;
};

}  // namespace isoslab

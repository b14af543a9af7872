// Phantoms: volumes computed from analytic fields, slice by slice, with no file.
//
// Named wherever an input is accepted as  phantom:NAME?key=value&key=value , for example
// "phantom:sphere?n=64&r=20&field=distance". Keys common to every phantom:
//   n        cube edge "64", or "nx,ny,nz"                      (default per phantom)
//   type     voxel type u8 i8 u16 i16 u32 i32 f32 f64            (default per phantom)
//   spacing  "s" or "sx,sy,sz", physical voxel size              (default 1,1,1)
//   c        centre "cx,cy,cz" in voxel units                    (default the grid centre)
// Phantoms and their own keys:
//   sphere   r (radius, voxels), field=distance|binary. distance: value = 1000 - 10*|p - c|,
//            suggested iso 1000 - 10*r, default type f32. binary: 100 where |p - c| <= r, else 0,
//            suggested iso 50, default type u8.
//   box      lo, hi: inclusive voxel corners "x,y,z" of the inside block (value 100, outside 0),
//            suggested iso 50, default type u8. Default: the middle third of the grid.
//   torus    R (major radius), r (minor radius), around the z axis through c; field as for the
//            sphere, with |p - c| replaced by the distance to the tube's core circle.
//   head     a noisy CT-like head: air -1000, soft tissue about 40, skull bone about 700, brain
//            about 35, in HU, as i16. seed (default 1), noise (standard deviation, default 20).
//            Suggested iso -400 (skin); 300 gives bone.
// Label maps (VolumeInfo::labelMap; background 0):
//   nested   labels 1, 2, 3: a ball of radius r/3 and shells out to 2r/3 and r (r: 0.4 of the
//            smallest edge), u8.
//   boxes    count (default 3) boxes labelled 1 .. count side by side along x, touching face to
//            face, in the middle half of y and z, u8.
//   checker  blocks of b (default 4) voxels filling the volume, labelled 1 .. labels (default 8)
//            in turn along x, then y, then z, u16.
//   voxel    label 1 at the centre voxel (default n 5), u8.
//   touch    two voxels of label 1 that touch at=face|edge|corner (default edge; n 6), u8.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "io/slice_source.h"

namespace isoslab {

class PhantomSource final : public SliceSource {
 public:
  /// True if `input` names a phantom ("phantom:..."), whether or not the rest is valid.
  static bool isPhantom(std::string_view input) noexcept;

  /// Parses the spec; throws isoslab::Error naming the spec and the bad key or value.
  static std::unique_ptr<PhantomSource> open(const std::string& spec);

  const VolumeInfo& info() const noexcept override { return info_; }
  bool readSlice(std::span<float> slice) override;
  /// Computes nothing for the skipped slices.
  std::int64_t skipSlices(std::int64_t n) override;

  /// The field value at lattice point (i, j, k) before conversion to the voxel type.
  double value(std::int64_t i, std::int64_t j, std::int64_t k) const noexcept;

 private:
  enum class Kind : std::uint8_t { kSphere, kBox, kTorus, kHead, kNested, kBoxes, kChecker, kVoxel, kTouch };

  PhantomSource() = default;

  VolumeInfo info_;
  Kind kind_ = Kind::kSphere;
  bool binary_ = false;
  std::array<double, 3> centre_{};
  double radius_ = 0;       // sphere radius, torus minor radius
  double majorRadius_ = 0;  // torus
  std::array<std::int64_t, 3> lo_{};
  std::array<std::int64_t, 3> hi_{};
  std::uint64_t seed_ = 1;
  double noise_ = 20;
  std::int64_t nextSlice_ = 0;
  std::int64_t count_ = 0;  // boxes, checker labels; touch: the axes its second voxel steps along
  std::int64_t block_ = 4;  // checker
};

}  // namespace isoslab

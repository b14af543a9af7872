#include "extract/frame.h"

#include <cmath>

namespace isoslab {

LatticeFrame LatticeFrame::voxel() {
  return LatticeFrame();
}

LatticeFrame LatticeFrame::physical(const VolumeInfo& info) {
  LatticeFrame f;
  f.name_ = "physical";
  f.origin_ = info.origin;
  const auto& d = info.direction;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) f.linear_[3 * r + c] = d[3 * r + c] * info.spacing[c];
  }
  const auto& m = f.linear_;
  // Cofactors give the inverse transpose directly: inv(M)^T = cof(M) / det(M).
  std::array<double, 9> cof{m[4] * m[8] - m[5] * m[7], m[5] * m[6] - m[3] * m[8], m[3] * m[7] - m[4] * m[6],
                            m[2] * m[7] - m[1] * m[8], m[0] * m[8] - m[2] * m[6], m[1] * m[6] - m[0] * m[7],
                            m[1] * m[5] - m[2] * m[4], m[2] * m[3] - m[0] * m[5], m[0] * m[4] - m[1] * m[3]};
  f.determinant_ = m[0] * cof[0] + m[1] * cof[1] + m[2] * cof[2];
  for (int n = 0; n < 9; ++n) f.inverseT_[n] = cof[n] / f.determinant_;
  f.sliceOrigins_ = info.sliceOrigins;
  return f;
}

Vec3d LatticeFrame::map(double i, double j, double k) const noexcept {
  const auto& m = linear_;
  if (sliceOrigins_.empty()) {
    return {origin_[0] + m[0] * i + m[1] * j + m[2] * k, origin_[1] + m[3] * i + m[4] * j + m[5] * k,
            origin_[2] + m[6] * i + m[7] * j + m[8] * k};
  }
  const auto last = static_cast<double>(sliceOrigins_.size() - 1);
  const double kc = std::fmin(std::fmax(k, 0.0), last);
  const auto k0 = static_cast<std::size_t>(std::fmin(std::floor(kc), last - 1));
  const double t = kc - static_cast<double>(k0);
  const Vec3d& a = sliceOrigins_[k0];
  const Vec3d& b = sliceOrigins_[k0 + 1];
  Vec3d o{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
  return {o[0] + m[0] * i + m[1] * j, o[1] + m[3] * i + m[4] * j, o[2] + m[6] * i + m[7] * j};
}

Vec3d LatticeFrame::gradient(const Vec3d& g) const noexcept {
  const auto& m = inverseT_;
  return {m[0] * g[0] + m[1] * g[1] + m[2] * g[2], m[3] * g[0] + m[4] * g[1] + m[5] * g[2],
          m[6] * g[0] + m[7] * g[1] + m[8] * g[2]};
}

}  // namespace isoslab

#include "extract/frame.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace isoslab {

LatticeFrame LatticeFrame::voxel() {
  return LatticeFrame();
}

LatticeFrame LatticeFrame::forSpace(const VolumeInfo& info, const std::string& space) {
  if (space == "voxel") return voxel();
  if (space == "physical" || space == "lps") {
    LatticeFrame f = physical(info);
    if (space == "lps") f.name_ = "lps";
    return f;
  }
  if (space == "ras") {
    // Negating x and y is a rotation by 180 degrees about z: the handedness is unchanged.
    VolumeInfo ras = info;
    for (int c = 0; c < 3; ++c) {
      ras.direction[static_cast<std::size_t>(c)] = -info.direction[static_cast<std::size_t>(c)];
      ras.direction[static_cast<std::size_t>(3 + c)] = -info.direction[static_cast<std::size_t>(3 + c)];
    }
    ras.origin = {-info.origin[0], -info.origin[1], info.origin[2]};
    for (auto& o : ras.sliceOrigins) o = {-o[0], -o[1], o[2]};
    LatticeFrame f = physical(ras);
    f.name_ = "ras";
    return f;
  }
  throw Error("unknown output space '" + space + "' (voxel, physical, lps or ras)");
}

LatticeFrame LatticeFrame::physical(const VolumeInfo& info) {
  LatticeFrame f;
  f.name_ = info.frame;
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

Vec3d LatticeFrame::mapPerSlice(double i, double j, double k) const noexcept {
  // Between two slices, their origins interpolated; beyond the first or last slice (the label
  // complex's caps, half a voxel out), the nearest two extrapolated.
  const auto& m = linear_;
  const std::size_t n = sliceOrigins_.size();
  Vec3d o = sliceOrigins_[0];
  if (n >= 2) {
    const double top = static_cast<double>(n - 2);
    const double k0 = std::fmin(std::fmax(std::floor(k), 0.0), top);
    const double t = k - k0;
    const Vec3d& a = sliceOrigins_[static_cast<std::size_t>(k0)];
    const Vec3d& b = sliceOrigins_[static_cast<std::size_t>(k0) + 1];
    o = {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
  } else {
    o = {o[0] + m[2] * k, o[1] + m[5] * k, o[2] + m[8] * k};
  }
  return {o[0] + m[0] * i + m[1] * j, o[1] + m[3] * i + m[4] * j, o[2] + m[6] * i + m[7] * j};
}

std::array<double, 6> LatticeFrame::bounds(const std::array<std::int64_t, 3>& dims, double margin) const noexcept {
  std::array<double, 6> b{};
  for (int c = 0; c < 8; ++c) {
    const Vec3d p = map((c & 1) ? static_cast<double>(dims[0] - 1) + margin : -margin,
                        (c & 2) ? static_cast<double>(dims[1] - 1) + margin : -margin,
                        (c & 4) ? static_cast<double>(dims[2] - 1) + margin : -margin);
    for (std::size_t a = 0; a < 3; ++a) {
      b[a] = c == 0 ? p[a] : std::min(b[a], p[a]);
      b[a + 3] = c == 0 ? p[a] : std::max(b[a + 3], p[a]);
    }
  }
  return b;
}

std::optional<VolumeFaces> LatticeFrame::faces(const std::array<std::int64_t, 3>& dims, double margin) const {
  const double first = -margin;
  const double last[3] = {static_cast<double>(dims[0] - 1) + margin, static_cast<double>(dims[1] - 1) + margin,
                          static_cast<double>(dims[2] - 1) + margin};
  if (!(last[0] > first && last[1] > first && last[2] > first)) return std::nullopt;
  auto corner = [&](int c) {
    return map((c & 1) ? last[0] : first, (c & 2) ? last[1] : first, (c & 4) ? last[2] : first);
  };
  Vec3d centre{0, 0, 0};
  double scale = 0;
  for (int c = 0; c < 8; ++c) {
    const Vec3d p = corner(c);
    for (std::size_t a = 0; a < 3; ++a) {
      centre[a] += p[a] / 8;
      scale = std::max(scale, std::abs(p[a]));
    }
  }
  auto sub = [](const Vec3d& a, const Vec3d& b) { return Vec3d{a[0] - b[0], a[1] - b[1], a[2] - b[2]}; };
  auto dot = [](const Vec3d& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  VolumeFaces faces{};
  for (int axis = 0; axis < 3; ++axis) {
    const int u = 1 << ((axis + 1) % 3);
    const int v = 1 << ((axis + 2) % 3);
    for (int side = 0; side < 2; ++side) {
      const int base = side ? (1 << axis) : 0;
      const Vec3d o = corner(base);
      const Vec3d e1 = sub(corner(base | u), o);
      const Vec3d e2 = sub(corner(base | v), o);
      Vec3d n{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
      const double len = std::sqrt(dot(n, n));
      if (!(len > 0)) return std::nullopt;
      for (double& x : n) x /= len;
      if (dot(n, sub(o, centre)) < 0) n = {-n[0], -n[1], -n[2]};
      const double d = dot(n, o);
      // Every slice's corners on this face must lie on the plane (uneven or bent stacks).
      const double tolerance = 1e-6 * scale;
      const std::int64_t slices = axis == 2 ? 1 : dims[2];
      for (std::int64_t k = 0; k < slices; ++k) {
        for (int c = 0; c < 4; ++c) {
          const double kk = axis == 2 ? (side ? last[2] : first) : static_cast<double>(k);
          const double ii = axis == 0 ? (side ? last[0] : first) : ((c & 1) ? last[0] : first);
          const double jj = axis == 1 ? (side ? last[1] : first) : ((c & 2) ? last[1] : first);
          if (std::abs(dot(n, map(ii, jj, kk)) - d) > tolerance) return std::nullopt;
        }
      }
      faces[static_cast<std::size_t>(2 * axis + side)] = {n[0], n[1], n[2], d};
    }
  }
  return faces;
}

std::optional<LatticeBox> LatticeFrame::latticeBox(const std::array<double, 6>& box,
                                                   const std::array<std::int64_t, 3>& dims) const noexcept {
  auto inside = [&](const Vec3d& p) {
    return box[0] <= p[0] && p[0] <= box[3] && box[1] <= p[1] && p[1] <= box[4] && box[2] <= p[2] && p[2] <= box[5];
  };
  const double last = static_cast<double>(dims[0] - 1);
  std::optional<LatticeBox> found;
  for (std::int64_t k = 0; k < dims[2]; ++k) {
    for (std::int64_t j = 0; j < dims[1]; ++j) {
      const auto jd = static_cast<double>(j);
      const auto kd = static_cast<double>(k);
      // Along the row, a point moves by column 0 of the linear part per step of i, from c.
      const Vec3d c = map(0, jd, kd);
      double lo = 0;
      double hi = last;
      for (std::size_t r = 0; r < 3 && lo <= hi; ++r) {
        const double step = linear_[3 * r];
        if (step == 0) {
          if (!(box[r] <= c[r] && c[r] <= box[r + 3])) hi = -1;
          continue;
        }
        double a = (box[r] - c[r]) / step;
        double b = (box[r + 3] - c[r]) / step;
        if (a > b) std::swap(a, b);
        lo = std::fmax(lo, a);
        hi = std::fmin(hi, b);
      }
      // Rounding may move the cut's ends by a fraction of a step: widen by one point on either
      // side, then trim with the exact test.
      if (!(lo <= hi + 2)) continue;
      auto i0 = static_cast<std::int64_t>(std::fmax(std::floor(lo) - 1, 0.0));
      auto i1 = static_cast<std::int64_t>(std::fmin(std::ceil(hi) + 1, last));
      while (i0 <= i1 && !inside(map(static_cast<double>(i0), jd, kd))) ++i0;
      while (i1 >= i0 && !inside(map(static_cast<double>(i1), jd, kd))) --i1;
      if (i0 > i1) continue;
      if (!found) {
        found = LatticeBox{{i0, j, k}, {i1, j, k}};
        continue;
      }
      found->lo = {std::min(found->lo[0], i0), std::min(found->lo[1], j), std::min(found->lo[2], k)};
      found->hi = {std::max(found->hi[0], i1), std::max(found->hi[1], j), std::max(found->hi[2], k)};
    }
  }
  return found;
}

}  // namespace isoslab

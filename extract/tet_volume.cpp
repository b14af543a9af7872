#include "extract/tet_volume.h"

namespace isoslab {

double tetInsideVolume(const std::array<double, 4>& v, double volume, unsigned cas, double iso) noexcept {
  auto s = [&](int from, int to) {
    return (iso - v[static_cast<std::size_t>(from)]) /
           (v[static_cast<std::size_t>(to)] - v[static_cast<std::size_t>(from)]);
  };
  int in[4];
  int out[4];
  int nIn = 0;
  int nOut = 0;
  for (int k = 0; k < 4; ++k) ((cas >> k) & 1 ? in[nIn++] : out[nOut++]) = k;
  if (nIn == 1) {
    const int a = in[0];
    return volume * s(a, out[0]) * s(a, out[1]) * s(a, out[2]);
  }
  if (nIn == 3) {
    const int a = out[0];
    return volume * (1.0 - s(a, in[0]) * s(a, in[1]) * s(a, in[2]));
  }
  const double u = s(in[0], out[0]), w = s(in[1], out[0]);
  const double x = s(in[1], out[1]), vv = s(in[0], out[1]);
  return volume * (u * vv * (1.0 - x) + u * x * (1.0 - w) + w * x);
}

}  // namespace isoslab

#include "render/camera.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace isoslab::render {
namespace {

Vec3d scaled(const Vec3d& a, double s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
Vec3d plus(const Vec3d& a, const Vec3d& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
Vec3d unit(const Vec3d& a) {
  return scaled(a, 1 / norm(a));
}

struct Preset {
  const char* name;
  View view;
};
constexpr Preset kPresets[] = {{"front", {0, 0}}, {"back", {180, 0}},   {"left", {90, 0}}, {"right", {270, 0}},
                               {"top", {0, 90}},  {"bottom", {0, -90}}, {"iso", {45, 30}}};

}  // namespace

std::optional<View> presetView(const std::string& name) {
  for (const Preset& p : kPresets) {
    if (name == p.name) return p.view;
  }
  return std::nullopt;
}

const std::vector<std::string>& presetNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const Preset& p : kPresets) n.emplace_back(p.name);
    return n;
  }();
  return names;
}

Camera Camera::fit(const std::array<double, 6>& bounds, const View& view, bool ras, int width, int height) {
  // Patient directions in the mesh's frame: LPS has +x left, +y posterior, +z superior.
  const Vec3d anterior = ras ? Vec3d{0, 1, 0} : Vec3d{0, -1, 0};
  const Vec3d left = ras ? Vec3d{-1, 0, 0} : Vec3d{1, 0, 0};
  const Vec3d superior{0, 0, 1};
  const double az = view.azimuth * std::numbers::pi / 180;
  const double el = std::clamp(view.elevation, -90.0, 90.0) * std::numbers::pi / 180;
  // From the centre towards the eye.
  const Vec3d toEye =
      plus(plus(scaled(anterior, std::cos(el) * std::cos(az)), scaled(left, std::cos(el) * std::sin(az))),
           scaled(superior, std::sin(el)));
  Camera c;
  c.forward_ = unit(scaled(toEye, -1));
  // Up is superior projected onto the image plane. Looking straight down or up it is anterior
  // (turned by the azimuth), as on an axial slice: the top view shows the nose at the top.
  const Vec3d facing = plus(scaled(anterior, std::cos(az)), scaled(left, std::sin(az)));
  const Vec3d upWish = std::abs(std::cos(el)) < 1e-9 ? facing : superior;
  const Vec3d right = unit(cross(c.forward_, upWish));
  const Vec3d up = cross(right, c.forward_);
  const double roll = view.roll * std::numbers::pi / 180;
  c.right_ = plus(scaled(right, std::cos(roll)), scaled(up, -std::sin(roll)));
  c.up_ = plus(scaled(up, std::cos(roll)), scaled(right, std::sin(roll)));
  c.centre_ = {0.5 * (bounds[0] + bounds[3]), 0.5 * (bounds[1] + bounds[4]), 0.5 * (bounds[2] + bounds[5])};
  c.width_ = width;
  c.height_ = height;
  // The box's corners decide the scale: the largest extent along right and up.
  double halfRight = 0;
  double halfUp = 0;
  for (int k = 0; k < 8; ++k) {
    const Vec3d corner{bounds[(k & 1) ? 3 : 0], bounds[(k & 2) ? 4 : 1], bounds[(k & 4) ? 5 : 2]};
    const Vec3d d{corner[0] - c.centre_[0], corner[1] - c.centre_[1], corner[2] - c.centre_[2]};
    halfRight = std::max(halfRight, std::abs(dot(d, c.right_)));
    halfUp = std::max(halfUp, std::abs(dot(d, c.up_)));
  }
  const double usable = 0.92;
  const double sx = halfRight > 0 ? usable * 0.5 * width / halfRight : INFINITY;
  const double sy = halfUp > 0 ? usable * 0.5 * height / halfUp : INFINITY;
  c.scale_ = std::min(sx, sy);
  if (!std::isfinite(c.scale_)) c.scale_ = 1;
  return c;
}

}  // namespace isoslab::render

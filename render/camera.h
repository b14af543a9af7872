// Where a rendered image looks from: an orthographic camera fitted to a box, with the views that
// radiologists and 3D Slicer name (front is anterior in patient space).
//
// A view is an azimuth and an elevation about the box's centre, in patient terms: azimuth 0 looks
// from anterior, 90 from the patient's left, 180 from posterior, 270 from the right; elevation 90
// looks down from superior. The anterior, left and superior directions are those of the mesh's
// space: LPS (isoslab's physical frame, DICOM's and Slicer's) unless the space is RAS. Images are
// radiological: in the front view the patient's left is on the image's right.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/vec3.h"

namespace isoslab::render {

struct View {
  double azimuth = 0;    // degrees
  double elevation = 0;  // degrees, -90 .. 90
  /// Degrees the image turns clockwise about the view axis (180 turns a volume whose slices run
  /// from the top of the head down the right way up).
  double roll = 0;
};

/// front, back, left, right, top, bottom, iso (azimuth 45, elevation 30: front-left, from above).
std::optional<View> presetView(const std::string& name);
/// The preset names, in the order presetView() knows them.
const std::vector<std::string>& presetNames();

class Camera {
 public:
  /// Fits `bounds` (xmin ymin zmin xmax ymax zmax) into a width x height image, seen from `view`,
  /// with a margin of 4% on each side. `ras` when the mesh's space is RAS, not LPS.
  static Camera fit(const std::array<double, 6>& bounds, const View& view, bool ras, int width, int height);

  /// Pixel coordinates (x right, y down; pixel (i, j) covers [i, i+1) x [j, j+1)) and depth (larger
  /// is farther) of a point.
  Vec3d project(const Vec3d& p) const noexcept {
    const Vec3d d{p[0] - centre_[0], p[1] - centre_[1], p[2] - centre_[2]};
    return {0.5 * width_ + scale_ * dot(d, right_), 0.5 * height_ - scale_ * dot(d, up_), dot(d, forward_)};
  }
  /// The direction the camera looks along (from the eye into the scene), unit length.
  const Vec3d& forward() const noexcept { return forward_; }
  const Vec3d& right() const noexcept { return right_; }
  const Vec3d& up() const noexcept { return up_; }
  /// Pixels per unit of the mesh's coordinates.
  double scale() const noexcept { return scale_; }
  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }

 private:
  Vec3d centre_{};
  Vec3d forward_{}, right_{}, up_{};
  double scale_ = 1;
  int width_ = 0;
  int height_ = 0;
};

}  // namespace isoslab::render

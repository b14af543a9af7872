#include "render/rasterizer.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace isoslab::render {
namespace {

Vec3d toD(const Vec3f& v) {
  return {v.x, v.y, v.z};
}

// Twice the signed area of (a, b, p) in pixel coordinates: positive when p is left of a -> b as
// seen on screen with y down, i.e. counter-clockwise on the image.
double edge(const Vec3d& a, const Vec3d& b, double px, double py) {
  return (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0]);
}

// The top-left rule, for triangles made counter-clockwise on screen (positive area): a pixel centre
// exactly on an edge belongs to the triangle when the edge is a top or a left edge, so two
// triangles that share an edge never both cover (or both miss) a pixel on it.
bool ownsTies(const Vec3d& a, const Vec3d& b) {
  const double dx = b[0] - a[0];
  const double dy = b[1] - a[1];
  return dy < 0 || (dy == 0 && dx > 0);
}

std::uint8_t shade(std::uint8_t channel, double intensity) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(intensity, 0.0, 1.0) * channel));
}

}  // namespace

Rgb partColour(std::size_t part) {
  static constexpr Rgb kPalette[] = {{230, 159, 0}, {86, 180, 233}, {0, 158, 115},   {240, 228, 66},
                                     {0, 114, 178}, {213, 94, 0},   {204, 121, 167}, {170, 170, 170}};
  return kPalette[part % std::size(kPalette)];
}

bool isRas(const std::string& space) {
  std::string s = space;
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s == "ras";
}

Rasterizer::Rasterizer(const Camera& camera, const Style& style) : camera_(camera), style_(style) {
  const auto pixels = static_cast<std::size_t>(camera.width()) * static_cast<std::size_t>(camera.height());
  depth_.assign(pixels, std::numeric_limits<float>::infinity());
  rgb_.resize(3 * pixels);
  for (std::size_t p = 0; p < pixels; ++p) {
    for (std::size_t c = 0; c < 3; ++c) rgb_[3 * p + c] = style.background[c];
  }
}

void Rasterizer::draw(const std::array<Vec3f, 3>& corners, const std::array<Vec3f, 3>* normals, const Rgb* colour) {
  std::array<Vec3d, 3> s{camera_.project(toD(corners[0])), camera_.project(toD(corners[1])),
                         camera_.project(toD(corners[2]))};
  // The face normal decides front or back; headlight: the light comes from the eye.
  const Vec3d p0 = toD(corners[0]);
  const Vec3d e1{corners[1].x - p0[0], corners[1].y - p0[1], corners[1].z - p0[2]};
  const Vec3d e2{corners[2].x - p0[0], corners[2].y - p0[1], corners[2].z - p0[2]};
  const Vec3d n = cross(e1, e2);
  const double length = norm(n);
  if (!(length > 0)) return;  // degenerate: covers no area
  const Vec3d& f = camera_.forward();
  const double facing = -dot(n, f) / length;  // cos of the angle between the normal and the eye
  const bool front = facing > 0;
  const Rgb base = front ? (colour != nullptr ? *colour : style_.colour) : style_.backColour;
  const double ambient = style_.ambient;
  std::array<double, 3> light{};
  for (std::size_t k = 0; k < 3; ++k) {
    double cosine = std::abs(facing);
    if (normals != nullptr && style_.smooth) {
      const Vec3f& m = (*normals)[k];
      cosine = std::max(0.0, (front ? -1.0 : 1.0) * (m.x * f[0] + m.y * f[1] + m.z * f[2]));
    }
    light[k] = ambient + (1 - ambient) * cosine;
  }
  // Screen winding: make it counter-clockwise on the image for the edge tests.
  double area = edge(s[0], s[1], s[2][0], s[2][1]);
  if (area == 0) return;
  if (area < 0) {
    std::swap(s[1], s[2]);
    std::swap(light[1], light[2]);
    area = -area;
  }
  const int w = camera_.width();
  const int h = camera_.height();
  const double minX = std::min({s[0][0], s[1][0], s[2][0]});
  const double maxX = std::max({s[0][0], s[1][0], s[2][0]});
  const double minY = std::min({s[0][1], s[1][1], s[2][1]});
  const double maxY = std::max({s[0][1], s[1][1], s[2][1]});
  // Pixel centres x + 0.5 within [minX, maxX].
  const int x0 = std::max(0, static_cast<int>(std::ceil(minX - 0.5)));
  const int x1 = std::min(w - 1, static_cast<int>(std::floor(maxX - 0.5)));
  const int y0 = std::max(0, static_cast<int>(std::ceil(minY - 0.5)));
  const int y1 = std::min(h - 1, static_cast<int>(std::floor(maxY - 0.5)));
  const bool tie[3] = {ownsTies(s[1], s[2]), ownsTies(s[2], s[0]), ownsTies(s[0], s[1])};
  for (int y = y0; y <= y1; ++y) {
    const double py = y + 0.5;
    for (int x = x0; x <= x1; ++x) {
      const double px = x + 0.5;
      const double b0 = edge(s[1], s[2], px, py);
      const double b1 = edge(s[2], s[0], px, py);
      const double b2 = edge(s[0], s[1], px, py);
      if (b0 < 0 || b1 < 0 || b2 < 0) continue;
      if ((b0 == 0 && !tie[0]) || (b1 == 0 && !tie[1]) || (b2 == 0 && !tie[2])) continue;
      const double l0 = b0 / area;
      const double l1 = b1 / area;
      const double l2 = 1 - l0 - l1;
      const auto z = static_cast<float>(l0 * s[0][2] + l1 * s[1][2] + l2 * s[2][2]);
      const std::size_t at = static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
      if (!(z < depth_[at])) continue;
      if (depth_[at] == std::numeric_limits<float>::infinity()) ++covered_;
      depth_[at] = z;
      const double intensity = l0 * light[0] + l1 * light[1] + l2 * light[2];
      for (std::size_t c = 0; c < 3; ++c) rgb_[3 * at + c] = shade(base[c], intensity);
    }
  }
}

Image Rasterizer::image() const {
  return Image{camera_.width(), camera_.height(), rgb_};
}

RenderSink::RenderSink(const View& view, int width, int height, const Style& style)
    : view_(view), width_(width), height_(height), style_(style) {}

void RenderSink::begin(const MeshHeader& header) {
  raster_.emplace(Camera::fit(header.volumeBounds, view_, isRas(header.space), width_, height_), style_);
  window_ = VertexWindow{};
  normals_ = header.normals;
}

void RenderSink::consume(const MeshChunk& chunk) {
  window_.push(chunk);
  const bool withNormals = normals_ && !chunk.normals.empty();
  for (const Triangle& t : chunk.triangles) {
    const std::array<Vec3f, 3> corners{window_.position(t[0]), window_.position(t[1]), window_.position(t[2])};
    if (withNormals) {
      const std::array<Vec3f, 3> normals{window_.normal(t[0]), window_.normal(t[1]), window_.normal(t[2])};
      raster_->draw(corners, &normals);
    } else {
      raster_->draw(corners, nullptr);
    }
  }
}

Image RenderSink::image() const {
  return raster_ ? raster_->image() : Image{};
}

}  // namespace isoslab::render

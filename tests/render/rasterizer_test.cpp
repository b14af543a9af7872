// The rasterizer against geometry worked out by hand: where silhouettes fall, how much of the image
// they cover (the analytic orthographic projection), and which way the light falls.
#include "render/rasterizer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "encode/indexed_mesh.h"

namespace isoslab::render {
namespace {

// The unit cube [0,1]^3 with outward normals: each face counter-clockwise seen from outside.
IndexedMesh cube(double lo = 0, double hi = 1) {
  IndexedMesh m;
  for (int k = 0; k < 8; ++k) {
    m.positions.push_back({static_cast<float>(k & 1 ? hi : lo), static_cast<float>(k & 2 ? hi : lo),
                           static_cast<float>(k & 4 ? hi : lo)});
  }
  // Quads (a, b, c, d) counter-clockwise from outside.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back({static_cast<VertexId>(q[0]), static_cast<VertexId>(q[1]), static_cast<VertexId>(q[2])});
    m.triangles.push_back({static_cast<VertexId>(q[0]), static_cast<VertexId>(q[2]), static_cast<VertexId>(q[3])});
  }
  return m;
}

// A UV sphere of radius 1 at the origin, outward normals, `n` segments around and n/2 from pole to
// pole.
IndexedMesh sphere(int n) {
  IndexedMesh m;
  const int rings = n / 2;
  for (int i = 0; i <= rings; ++i) {
    const double theta = std::numbers::pi * i / rings;
    for (int j = 0; j < n; ++j) {
      const double phi = 2 * std::numbers::pi * j / n;
      const Vec3f p{static_cast<float>(std::sin(theta) * std::cos(phi)),
                    static_cast<float>(std::sin(theta) * std::sin(phi)), static_cast<float>(std::cos(theta))};
      m.positions.push_back(p);
      m.normals.push_back(p);
    }
  }
  auto id = [n](int i, int j) { return static_cast<VertexId>(i * n + (j % n)); };
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < n; ++j) {
      // Counter-clockwise seen from outside: theta grows downwards from the north pole.
      if (i > 0) m.triangles.push_back({id(i, j), id(i + 1, j), id(i, j + 1)});
      if (i + 1 < rings) m.triangles.push_back({id(i, j + 1), id(i + 1, j), id(i + 1, j + 1)});
    }
  }
  return m;
}

Image render(const IndexedMesh& m, const std::array<double, 6>& bounds, const View& view, int size, bool smooth,
             bool ras = false) {
  Style style;
  style.smooth = smooth;
  Rasterizer r(Camera::fit(bounds, view, ras, size, size), style);
  for (const Triangle& t : m.triangles) {
    const std::array<Vec3f, 3> c{m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]};
    if (!m.normals.empty()) {
      const std::array<Vec3f, 3> n{m.normals[t[0]], m.normals[t[1]], m.normals[t[2]]};
      r.draw(c, &n);
    } else {
      r.draw(c, nullptr);
    }
  }
  return r.image();
}

bool isBackground(const Image& im, int x, int y) {
  return im.pixel(x, y) == Rgb{255, 255, 255};
}

double coveredFraction(const Image& im) {
  std::int64_t covered = 0;
  for (int y = 0; y < im.height; ++y) {
    for (int x = 0; x < im.width; ++x) covered += isBackground(im, x, y) ? 0 : 1;
  }
  return static_cast<double>(covered) / (static_cast<double>(im.width) * im.height);
}

// Seen from the front, the unit cube fitted to its own box is a square of 92% of the image side
// (the 4% margins), centred.
TEST(Rasterizer, CubeFromTheFrontIsTheCentredSquare) {
  const Image im = render(cube(), {0, 0, 0, 1, 1, 1}, *presetView("front"), 200, false);
  EXPECT_NEAR(coveredFraction(im), 0.92 * 0.92, 0.01);
  // The square spans pixels 8 .. 191 (centres 8.5 .. 191.5 inside [8, 192]).
  EXPECT_TRUE(isBackground(im, 7, 100));
  EXPECT_FALSE(isBackground(im, 8, 100));
  EXPECT_FALSE(isBackground(im, 191, 100));
  EXPECT_TRUE(isBackground(im, 192, 100));
  EXPECT_TRUE(isBackground(im, 100, 7));
  EXPECT_FALSE(isBackground(im, 100, 8));
  // The face seen head-on is lit fully: its colour exactly.
  EXPECT_EQ(im.pixel(100, 100), Style{}.colour);
}

// The iso view of a cube: a regular hexagon when seen along a diagonal; from azimuth 45 and
// elevation atan(1/sqrt 2) its area is sqrt(3) (the projection of the unit cube along (1,1,1)).
TEST(Rasterizer, CubeAlongItsDiagonalCoversTheHexagonsArea) {
  const View diagonal{45, std::atan(1 / std::sqrt(2.0)) * 180 / std::numbers::pi};
  const int size = 400;
  Style style;
  const Camera camera = Camera::fit({0, 0, 0, 1, 1, 1}, diagonal, false, size, size);
  const Image im = render(cube(), {0, 0, 0, 1, 1, 1}, diagonal, size, false);
  const double expected = std::sqrt(3.0) * camera.scale() * camera.scale() / (size * size);
  EXPECT_NEAR(coveredFraction(im) / expected, 1.0, 0.01);
}

// A unit sphere's silhouette is a disc of radius `scale`, whatever the view.
TEST(Rasterizer, SphereCoversItsDisc) {
  const IndexedMesh s = sphere(160);
  for (const char* name : {"front", "left", "top", "iso"}) {
    SCOPED_TRACE(name);
    const int size = 300;
    const Camera camera = Camera::fit({-1, -1, -1, 1, 1, 1}, *presetView(name), false, size, size);
    const Image im = render(s, {-1, -1, -1, 1, 1, 1}, *presetView(name), size, true);
    const double disc = std::numbers::pi * camera.scale() * camera.scale() / (size * size);
    EXPECT_NEAR(coveredFraction(im) / disc, 1.0, 0.01);
    EXPECT_TRUE(isBackground(im, 0, 0));
    EXPECT_FALSE(isBackground(im, size / 2, size / 2));
  }
}

// Lit from the eye, a sphere is brightest where its normal faces the eye: the centre pixel.
TEST(Rasterizer, NormalsFaceTheLight) {
  const IndexedMesh s = sphere(120);
  for (const bool smooth : {true, false}) {
    SCOPED_TRACE(smooth ? "smooth" : "flat");
    const int size = 101;
    const Image im = render(s, {-1, -1, -1, 1, 1, 1}, *presetView("front"), size, smooth);
    int brightest = 0;
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        if (!isBackground(im, x, y)) brightest = std::max(brightest, static_cast<int>(im.pixel(x, y)[0]));
      }
    }
    EXPECT_EQ(im.pixel(size / 2, size / 2)[0], brightest);
    // Towards the rim the light falls off.
    EXPECT_LT(im.pixel(size / 2 + 40, size / 2)[0], brightest / 2 + 30);
  }
  // Inverted winding: the faces that the eye sees are back faces, drawn in the back colour.
  IndexedMesh inverted = s;
  for (Triangle& t : inverted.triangles) std::swap(t[1], t[2]);
  inverted.normals.clear();
  const Image im = render(inverted, {-1, -1, -1, 1, 1, 1}, *presetView("front"), 101, false);
  // The far half of the sphere is the nearest surface seen from behind: back colour at the centre.
  const Rgb back = Style{}.backColour;
  EXPECT_EQ(im.pixel(50, 50), back);
}

// Front is anterior, radiologically: the patient's left (+x in LPS, -x in RAS) is on the right.
TEST(Rasterizer, FrontViewShowsThePatientsLeftOnTheRight) {
  const IndexedMesh m = cube(0.6, 1.0);  // a small cube at +x, +y, +z of the box [-1,1]^3
  const std::array<double, 6> box{-1, -1, -1, 1, 1, 1};
  const Image lps = render(m, box, *presetView("front"), 100, false);
  const Image ras = render(m, box, *presetView("front"), 100, false, true);
  const Image top = render(m, box, *presetView("top"), 100, false);
  // +x is the patient's left in LPS: on the right; +z superior: at the top.
  EXPECT_FALSE(isBackground(lps, 90, 10));
  EXPECT_TRUE(isBackground(lps, 10, 10));
  // In RAS +x is the patient's right: on the left.
  EXPECT_FALSE(isBackground(ras, 10, 10));
  EXPECT_TRUE(isBackground(ras, 90, 10));
  // From the top, anterior is at the top of the image; +y is posterior in LPS: at the bottom.
  EXPECT_FALSE(isBackground(top, 10, 90));
  EXPECT_TRUE(isBackground(top, 10, 10));
}

// The same triangles give the same bytes; two triangles sharing an edge cover each pixel once.
TEST(Rasterizer, DeterministicAndWatertight) {
  const IndexedMesh s = sphere(64);
  const Image a = render(s, {-1, -1, -1, 1, 1, 1}, *presetView("iso"), 128, true);
  const Image b = render(s, {-1, -1, -1, 1, 1, 1}, *presetView("iso"), 128, true);
  EXPECT_EQ(a.rgb, b.rgb);
  // A square split along its diagonal covers every pixel of a 16 x 16 image: the shared edge drops none.
  Style style;
  Rasterizer r(Camera::fit({0, 0, 0, 1, 0, 1}, *presetView("front"), false, 16, 16), style);
  // Whole image: the fitted square is 92% of 16 pixels; draw a bigger one to cover every centre.
  const Vec3f p00{-1, 0.5f, -1}, p10{2, 0.5f, -1}, p11{2, 0.5f, 2}, p01{-1, 0.5f, 2};
  r.draw({p00, p10, p11}, nullptr);
  EXPECT_LT(r.coveredPixels(), 256);
  r.draw({p00, p11, p01}, nullptr);
  EXPECT_EQ(r.coveredPixels(), 256);
}

}  // namespace
}  // namespace isoslab::render

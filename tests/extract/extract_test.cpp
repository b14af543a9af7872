#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <set>

#include "encode/indexed_mesh.h"
#include "extract/frame.h"
#include "io/open_source.h"
#include "io/phantom.h"
#include "io/volume_writer.h"
#include "test_support.h"

namespace isoslab {
namespace {

using testing::Extraction;
using testing::kAllMethods;

std::string name(Method m) {
  return std::string(methodName(m));
}

const char* kBlock = "phantom:box?n=10&lo=2,2,2&hi=7,7,7";

// 6 x 6 x 6 inside lattice points (value 100) in a 10^3 grid of zeros, iso 50.
//
// mc: the cells that straddle the block are
//   face cells, 6 faces x 5 x 5, four inside corners (a plane): 2 triangles each   = 300
//   edge cells, 12 edges x 5, two inside corners: 2 triangles each                 = 120
//   corner cells, 8, one inside corner: 1 triangle each                            =   8
// 428 triangles; one vertex per crossed lattice edge, 6 x 6 x 6 surface points = 216.
//
// mt6 (tetrahedra 0 -> a -> a+b -> 7 for the 6 orders of the axes a, b, c):
//   face cells: 1 + 1 + 2 + 2 + 1 + 1 = 8 triangles per cell on every face (the split is
//     symmetric under axis permutations and under the inversion 0 <-> 7)          = 1200
//   edge cells: an edge whose two inside corners lie on a line parallel to the main diagonal's
//     projection (local corners (0,0) or (1,1) in the other two axes) gives 2+2+1+1+1+1 = 8,
//     the other two edges per axis give 2+1+1 = 4; per axis 2x5x8 + 2x5x4 = 120     =  360
//   corner cells: corners 0 and 7 lie in all 6 tetrahedra (6 triangles), the other six in 2
//     (2 triangles): 6 + 6 + 6 x 2                                                  =   24
// 1584 triangles.
// mt5 and bcc12: counted below, tetrahedron by tetrahedron, from the decompositions' definitions
// (written here again, independently of extract/cell_schemes.cpp): a tetrahedron with one or three
// nodes inside gives one triangle, with two inside two.
namespace block {

double corner(std::int64_t i, std::int64_t j, std::int64_t k) {
  return i >= 2 && i <= 7 && j >= 2 && j <= 7 && k >= 2 && k <= 7 ? 100.0 : 0.0;
}

int triangles(std::initializer_list<double> nodes) {
  int inside = 0;
  for (double v : nodes) inside += v >= 50.0 ? 1 : 0;
  return inside == 2 ? 2 : (inside == 1 || inside == 3) ? 1 : 0;
}

// mt5: cell (i, j, k) with corner c at (i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)); even
// i + j + k cuts off corners 1, 2, 4, 7 (each with its three axis neighbours), leaving the central
// tetrahedron 0, 3, 5, 6; odd i + j + k cuts off 0, 3, 5, 6 around the centre 1, 2, 4, 7.
std::uint64_t mt5() {
  std::uint64_t total = 0;
  for (std::int64_t k = 0; k < 9; ++k) {
    for (std::int64_t j = 0; j < 9; ++j) {
      for (std::int64_t i = 0; i < 9; ++i) {
        auto v = [&](int c) { return corner(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)); };
        const bool even = (i + j + k) % 2 == 0;
        const std::array<int, 4> cut = even ? std::array{1, 2, 4, 7} : std::array{0, 3, 5, 6};
        const std::array<int, 4> centre = even ? std::array{0, 3, 5, 6} : std::array{1, 2, 4, 7};
        for (int c : cut) total += static_cast<std::uint64_t>(triangles({v(c), v(c ^ 1), v(c ^ 2), v(c ^ 4)}));
        total += static_cast<std::uint64_t>(triangles({v(centre[0]), v(centre[1]), v(centre[2]), v(centre[3])}));
      }
    }
  }
  return total;
}

// bcc12: a cell's centre is the mean of its corners. Each cell owns its +x, +y and +z faces: the
// four tetrahedra of its centre, the neighbour's centre and one edge of the face; a face on the
// volume's boundary (either side) is a pyramid to the cell's centre, split along the diagonal
// through the face's lowest corner.
std::uint64_t bcc12() {
  auto centre = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    double sum = 0;
    for (int c = 0; c < 8; ++c) sum += corner(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1));
    return sum / 8;
  };
  std::uint64_t total = 0;
  for (std::int64_t k = 0; k < 9; ++k) {
    for (std::int64_t j = 0; j < 9; ++j) {
      for (std::int64_t i = 0; i < 9; ++i) {
        const std::array<std::int64_t, 3> cell{i, j, k};
        const double own = centre(i, j, k);
        for (int axis = 0; axis < 3; ++axis) {
          const int u = (axis + 1) % 3, w = (axis + 2) % 3;
          // The face's corners at offset `side` along the axis, (0,0), (1,0), (0,1), (1,1) in (u, w).
          auto faceCorner = [&](int side, int du, int dw) {
            std::array<std::int64_t, 3> p = cell;
            p[static_cast<std::size_t>(axis)] += side;
            p[static_cast<std::size_t>(u)] += du;
            p[static_cast<std::size_t>(w)] += dw;
            return corner(p[0], p[1], p[2]);
          };
          auto pyramid = [&](int side) {
            return triangles({own, faceCorner(side, 0, 0), faceCorner(side, 1, 0), faceCorner(side, 1, 1)}) +
                   triangles({own, faceCorner(side, 0, 0), faceCorner(side, 0, 1), faceCorner(side, 1, 1)});
          };
          if (cell[static_cast<std::size_t>(axis)] == 0) total += static_cast<std::uint64_t>(pyramid(0));
          if (cell[static_cast<std::size_t>(axis)] == 8) {
            total += static_cast<std::uint64_t>(pyramid(1));
            continue;
          }
          std::array<std::int64_t, 3> next = cell;
          ++next[static_cast<std::size_t>(axis)];
          const double other = centre(next[0], next[1], next[2]);
          const double a = faceCorner(1, 0, 0), b = faceCorner(1, 1, 0), c = faceCorner(1, 0, 1),
                       d = faceCorner(1, 1, 1);
          for (auto [p, q] : {std::pair{a, b}, std::pair{b, d}, std::pair{d, c}, std::pair{c, a}}) {
            total += static_cast<std::uint64_t>(triangles({own, other, p, q}));
          }
        }
      }
    }
  }
  return total;
}

// mt24: six pyramids from the cube's centre (the mean of its 8 corners), one per face, each cut
// into four tetrahedra through the face's centre (the mean of the face's 4 corners): (cube
// centre, face centre, the two ends of one face edge).
std::uint64_t mt24() {
  std::uint64_t total = 0;
  for (std::int64_t k = 0; k < 9; ++k) {
    for (std::int64_t j = 0; j < 9; ++j) {
      for (std::int64_t i = 0; i < 9; ++i) {
        auto v = [&](int c) { return corner(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)); };
        double own = 0;
        for (int c = 0; c < 8; ++c) own += v(c) / 8;
        for (int axis = 0; axis < 3; ++axis) {
          const int u = 1 << ((axis + 1) % 3), w = 1 << ((axis + 2) % 3);
          for (int side = 0; side < 2; ++side) {
            const int base = side << axis;
            const std::array<double, 4> ring{v(base), v(base | u), v(base | u | w), v(base | w)};
            const double face = (ring[0] + ring[1] + ring[2] + ring[3]) / 4;
            for (std::size_t m = 0; m < 4; ++m) {
              total += static_cast<std::uint64_t>(triangles({own, face, ring[m], ring[(m + 1) % 4]}));
            }
          }
        }
      }
    }
  }
  return total;
}

}  // namespace block

TEST(ExtractBlock, ExactTriangleCounts) {
  struct Expect {
    Method method;
    std::uint64_t triangles;
  };
  for (const Expect& e :
       {Expect{Method::kMarchingCubes, 428}, Expect{Method::kTetra5, block::mt5()}, Expect{Method::kTetra6, 1584},
        Expect{Method::kBcc12, block::bcc12()}, Expect{Method::kTetra24, block::mt24()}}) {
    const Extraction x = testing::extract(kBlock, e.method, 50);
    EXPECT_EQ(x.stats.triangles, e.triangles) << name(e.method);
    EXPECT_TRUE(x.stats.closed()) << name(e.method);
    EXPECT_EQ(x.stats.inconsistentEdges, 0u) << name(e.method);
    EXPECT_EQ(x.stats.euler, 2) << name(e.method);
    // bcc12's centre values on the block's faces are the mean of four 100s and four 0s, and so
    // are mt24's face centres on the faces across the block's edges: exactly the iso value, so
    // vertices land on those centres and some triangles collapse.
    if (e.method != Method::kBcc12 && e.method != Method::kTetra24) {
      EXPECT_EQ(x.stats.degenerateTriangles, 0u) << name(e.method);
    }
  }
  EXPECT_EQ(testing::extract(kBlock, Method::kMarchingCubes, 50).stats.vertices, 216u);
  // The brute-force counts themselves, as first found by hand-checked enumeration.
  EXPECT_EQ(block::mt5(), 1220u);
  EXPECT_EQ(block::bcc12(), 2424u);
}

// Inside is value >= iso compared exactly, also for iso values that no float equals: float(0.1)
// is above the double 0.1 and below the next double after it.
TEST(ExtractBlock, IsoValuesBetweenFloatsCompareExactly) {
  const float stored = 0.1f;
  auto field = [stored](std::int64_t i, std::int64_t j, std::int64_t k) {
    const bool in = i >= 2 && i <= 7 && j >= 2 && j <= 7 && k >= 2 && k <= 7;
    return in ? stored : 0.0f;
  };
  for (Method m : kAllMethods) {
    testing::VectorSource below({10, 10, 10}, field);
    EXPECT_GT(testing::extract(below, m, 0.1).stats.triangles, 0u) << name(m);
    testing::VectorSource at({10, 10, 10}, field);
    EXPECT_GT(testing::extract(at, m, static_cast<double>(stored)).stats.triangles, 0u) << name(m);
    testing::VectorSource above({10, 10, 10}, field);
    const double justAbove = std::nextafter(static_cast<double>(stored), 1.0);
    EXPECT_EQ(testing::extract(above, m, justAbove).stats.triangles, 0u) << name(m);
  }
  testing::VectorSource block({10, 10, 10}, field);
  EXPECT_EQ(testing::extract(block, Method::kMarchingCubes, 0.1).stats.triangles, 428u);
}

// Row spans (used to skip uniform runs) against their definition: the first and last i >= 1 whose
// state differs from voxel i - 1, -1 for a uniform row; NaN is never inside. Rows of 50 voxels
// cover whole 16-voxel blocks and a tail, with changes on both sides of block borders.
TEST(RowSpans, MatchTheirDefinition) {
  constexpr std::int64_t nx = 50;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<std::vector<float>> rows;
  rows.push_back(std::vector<float>(nx, 0.0f));
  rows.push_back(std::vector<float>(nx, 1.0f));
  for (std::int64_t at : {1, 15, 16, 17, 31, 32, 33, 47, 48, 49}) {
    std::vector<float> up(nx, 0.0f);
    std::fill(up.begin() + at, up.end(), 1.0f);
    rows.push_back(up);
    std::vector<float> blip(nx, 1.0f);
    blip[static_cast<std::size_t>(at)] = nan;
    rows.push_back(blip);
  }
  std::mt19937 rng(11);
  for (int r = 0; r < 40; ++r) {
    std::vector<float> row(nx, static_cast<float>(r % 2));
    const int changes = r % 4;
    for (int c = 0; c < changes; ++c) {
      const auto at = static_cast<std::size_t>(rng() % nx);
      const float v = rng() % 3 == 0 ? nan : 1.0f - row[at];
      row[at] = v;
    }
    rows.push_back(row);
  }
  VolumeInfo info;
  info.dims = {nx, static_cast<std::int64_t>(rows.size()), 2};
  ExtractOptions o;
  o.iso = 0.5;
  auto ex = makeExtractor(o, info, LatticeFrame::voxel());
  std::vector<float> slice;
  for (const auto& r : rows) slice.insert(slice.end(), r.begin(), r.end());
  std::vector<RowSpan> spans;
  ex->classifySlice(slice.data(), spans);
  ASSERT_EQ(spans.size(), rows.size());
  for (std::size_t r = 0; r < rows.size(); ++r) {
    auto inside = [&](std::int64_t i) { return rows[r][static_cast<std::size_t>(i)] >= 0.5f; };
    RowSpan want;
    want.left = inside(0);
    want.right = inside(nx - 1);
    for (std::int64_t i = 1; i < nx; ++i) {
      if (inside(i) != inside(i - 1)) {
        if (want.first < 0) want.first = i;
        want.last = i;
      }
    }
    EXPECT_EQ(spans[r].first, want.first) << "row " << r;
    EXPECT_EQ(spans[r].last, want.last) << "row " << r;
    EXPECT_EQ(spans[r].left, want.left) << "row " << r;
    EXPECT_EQ(spans[r].right, want.right) << "row " << r;
  }
}

TEST(ExtractBlock, ValuesEqualToIsoGiveDegenerateTrianglesButNoHole) {
  // Inside means value >= iso: with iso 100 every inside corner is exactly on the surface, so
  // several vertices coincide and triangles collapse, but the mesh stays closed in index terms.
  for (Method m : kAllMethods) {
    const Extraction x = testing::extract(kBlock, m, 100);
    EXPECT_GT(x.stats.degenerateTriangles, 0u) << name(m);
    EXPECT_TRUE(x.stats.closed()) << name(m);
    EXPECT_EQ(x.stats.inconsistentEdges, 0u) << name(m);
    EXPECT_EQ(x.stats.euler, 2) << name(m);
  }
}

TEST(ExtractSphere, ClosedOrientedAndAccurateForEveryMethod) {
  const double r = 20;
  const double area = 4 * std::numbers::pi * r * r;
  const double volume = 4.0 / 3.0 * std::numbers::pi * r * r * r;
  for (Method m : kAllMethods) {
    const Extraction x = testing::extract("phantom:sphere?n=64&r=20&field=distance", m, 1000 - 10 * r);
    const MeshStats& s = x.stats;
    EXPECT_EQ(s.boundaryEdges, 0u) << name(m);
    EXPECT_EQ(s.nonManifoldEdges, 0u) << name(m);
    EXPECT_EQ(s.inconsistentEdges, 0u) << name(m);
    EXPECT_EQ(s.euler, 2) << name(m);
    EXPECT_NEAR(s.area / area, 1.0, 0.005) << name(m);
    EXPECT_NEAR(s.volume / volume, 1.0, 0.005) << name(m);
    if (m == Method::kMarchingCubes || m == Method::kMarchingCubes33) {
      EXPECT_FALSE(s.cellVolume.has_value());
    } else {
      ASSERT_TRUE(s.cellVolume.has_value()) << name(m);
      EXPECT_NEAR(*s.cellVolume / volume, 1.0, 0.005) << name(m);
      EXPECT_NEAR(*s.cellVolume / s.volume, 1.0, 1e-6) << name(m);
    }
  }
}

TEST(ExtractSphere, TetrahedralMethodsMakeMoreTrianglesThanMarchingCubes) {
  const auto count = [](Method m) { return testing::extract("phantom:sphere?n=48&r=15", m, 850).stats.triangles; };
  const auto mc = count(Method::kMarchingCubes);
  const auto mt5 = count(Method::kTetra5);
  const auto mt6 = count(Method::kTetra6);
  const auto bcc = count(Method::kBcc12);
  const auto mt24 = count(Method::kTetra24);
  EXPECT_LT(mc, mt5);
  EXPECT_LT(mt5, mt6);
  EXPECT_LT(mt6, bcc);
  EXPECT_LT(bcc, mt24);
}

// Two inside voxels diagonally across one face, (1,1,1) and (2,2,1), with the face's other two
// corners at 1 and everything else 0; iso 5. The bilinear saddle of the face, (AC - BD) / (A + C -
// B - D) with the values shifted by the iso value, decides whether the inside joins across it:
// with the inside voxels at 10 it is (25 - 16) / 18 > 0, one surface (Euler characteristic 2);
// at 6 it is (1 - 16) / 10 < 0, two (Euler characteristic 4). mc always separates (4).
TEST(ExtractMc33, TheFaceSaddleDecidesWhetherTwoVoxelsJoin) {
  for (const float high : {10.0f, 6.0f}) {
    std::vector<float> values(4 * 4 * 4, 0.0f);
    auto at = [&](int i, int j, int k) -> float& { return values[static_cast<std::size_t>((k * 4 + j) * 4 + i)]; };
    at(1, 1, 1) = at(2, 2, 1) = high;
    at(2, 1, 1) = at(1, 2, 1) = 1.0f;
    for (Method m : {Method::kMarchingCubes, Method::kMarchingCubes33}) {
      testing::VectorSource source({4, 4, 4}, values);
      const Extraction x = testing::extract(source, m, 5);
      EXPECT_TRUE(x.stats.closed()) << name(m);
      EXPECT_EQ(x.stats.inconsistentEdges, 0u) << name(m);
      const bool joined = m == Method::kMarchingCubes33 && high == 10.0f;
      EXPECT_EQ(x.stats.euler, joined ? 2 : 4) << name(m) << " at " << high;
    }
  }
}

// Union-find over n elements, with path halving.
struct Sets {
  explicit Sets(std::size_t n) : parent(n) {
    for (std::size_t k = 0; k < n; ++k) parent[k] = static_cast<std::uint32_t>(k);
  }
  std::uint32_t find(std::uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  void unite(std::uint32_t a, std::uint32_t b) { parent[find(a)] = find(b); }
  std::vector<std::uint32_t> parent;
};

// The surface components of the whole trilinear interpolant of a field, by brute force: the field
// sampled at 1/step of a voxel, its inside (>= iso) and outside samples labelled with
// 6-connectivity, and one surface per adjacent pair of an inside and an outside region (in a box,
// the regions and the surfaces between them form a tree).
std::size_t sampledSurfaces(const std::vector<float>& v, std::int64_t n, int step, double iso) {
  const std::int64_t m = (n - 1) * step + 1;
  auto value = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    const std::int64_t p[3] = {x, y, z};
    std::int64_t base[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
      base[a] = std::min(p[a] / step, n - 2);
      f[a] = static_cast<double>(p[a] - base[a] * step) / step;
    }
    double sum = 0;
    for (int c = 0; c < 8; ++c) {
      double w = 1;
      for (int a = 0; a < 3; ++a) w *= ((c >> a) & 1) ? f[a] : 1 - f[a];
      sum +=
          w *
          v[static_cast<std::size_t>(((base[2] + (c >> 2 & 1)) * n + base[1] + (c >> 1 & 1)) * n + base[0] + (c & 1))];
    }
    return sum;
  };
  const auto count = static_cast<std::size_t>(m * m * m);
  std::vector<std::uint8_t> inside(count);
  for (std::int64_t z = 0; z < m; ++z) {
    for (std::int64_t y = 0; y < m; ++y) {
      for (std::int64_t x = 0; x < m; ++x)
        inside[static_cast<std::size_t>((z * m + y) * m + x)] = value(x, y, z) >= iso;
    }
  }
  Sets sets(count);
  const std::int64_t strides[3] = {1, m, m * m};
  auto forNeighbours = [&](auto&& visit) {
    for (std::int64_t z = 0; z < m; ++z) {
      for (std::int64_t y = 0; y < m; ++y) {
        for (std::int64_t x = 0; x < m; ++x) {
          const std::int64_t p[3] = {x, y, z};
          const auto k = static_cast<std::uint32_t>((z * m + y) * m + x);
          for (int a = 0; a < 3; ++a) {
            if (p[a] + 1 < m) visit(k, static_cast<std::uint32_t>(k + strides[a]));
          }
        }
      }
    }
  };
  forNeighbours([&](std::uint32_t a, std::uint32_t b) {
    if (inside[a] == inside[b]) sets.unite(a, b);
  });
  std::set<std::pair<std::uint32_t, std::uint32_t>> pairs;
  forNeighbours([&](std::uint32_t a, std::uint32_t b) {
    if (inside[a] != inside[b])
      pairs.insert(inside[a] ? std::pair{sets.find(a), sets.find(b)} : std::pair{sets.find(b), sets.find(a)});
  });
  return pairs.size();
}

// Connected components of a mesh's triangles (through shared vertices).
std::size_t meshComponents(const IndexedMesh& mesh) {
  Sets sets(mesh.positions.size());
  for (const Triangle& t : mesh.triangles) {
    sets.unite(t[0], t[1]);
    sets.unite(t[1], t[2]);
  }
  std::set<std::uint32_t> roots;
  for (const Triangle& t : mesh.triangles) roots.insert(sets.find(t[0]));
  return roots.size();
}

// Random 12^3 fields of few levels around the iso value (saddles everywhere, about a third of the
// cells ambiguous): mc33's surface has exactly the trilinear interpolant's components, counted by
// brute force on the field sampled 16 times finer; mc's has many more (it splits the inside at
// every ambiguous face).
TEST(ExtractMc33, SurfaceComponentsAreTheTrilinearFieldsOnRandomFields) {
  const std::int64_t n = 12;
  const float levels[] = {-3.0f, -1.0f, -0.25f, 0.5f, 1.5f, 2.0f};
  for (unsigned seed = 1; seed <= 3; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> pick(0, 5);
    std::normal_distribution<float> noise(0.0f, 0.3f);
    std::vector<float> values(static_cast<std::size_t>(n * n * n));
    for (float& v : values) v = levels[pick(rng)] + noise(rng);
    const double iso = 0.1;
    const std::size_t reference = sampledSurfaces(values, n, 16, iso);
    testing::VectorSource mc33Source({n, n, n}, values);
    const Extraction mc33 = testing::extract(mc33Source, Method::kMarchingCubes33, iso);
    testing::VectorSource mcSource({n, n, n}, values);
    const Extraction mc = testing::extract(mcSource, Method::kMarchingCubes, iso);
    EXPECT_EQ(meshComponents(mc33.mesh), reference) << "seed " << seed;
    EXPECT_GT(meshComponents(mc.mesh), reference) << "seed " << seed;
    EXPECT_EQ(mc33.stats.nonManifoldEdges, 0u);
    EXPECT_EQ(mc33.stats.interiorBoundaryEdges, 0u);
    EXPECT_EQ(mc33.stats.inconsistentEdges, 0u);
  }
}

// --close-boundary: a sphere of radius 20 centred near the corner (5, 6, 7) of a 40^3 volume, cut
// by three of its faces. Capped, every method gives one closed, manifold, oriented surface, whose
// volume is the sphere's clipped to the box (integrated here column by column), with the caps'
// vertices exactly on the faces; 1 and 3 threads give the same mesh.
double clippedSphereVolume(const std::array<double, 3>& c, double r, double box) {
  const int n = 2000;
  const double h = box / n;
  double sum = 0;
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      const double x = (a + 0.5) * h - c[0], y = (b + 0.5) * h - c[1];
      const double d2 = r * r - x * x - y * y;
      if (d2 <= 0) continue;
      const double half = std::sqrt(d2);
      sum += std::clamp(c[2] + half, 0.0, box) - std::clamp(c[2] - half, 0.0, box);
    }
  }
  return sum * h * h;
}

TEST(ExtractCloseBoundary, ASphereCutByTheFacesIsClosedForEveryMethod) {
  const char* spec = "phantom:sphere?n=40&r=20&c=5,6,7&field=distance";
  const double truth = clippedSphereVolume({5, 6, 7}, 20, 39);
  for (Method m : kAllMethods) {
    ExtractOptions options;
    options.method = m;
    options.iso = 800;
    options.normals = true;
    options.closeBoundary = true;
    const Extraction x = testing::extract(openSource(spec, {}), options);
    const MeshStats& s = x.stats;
    EXPECT_EQ(s.boundaryEdges, 0u) << name(m);
    EXPECT_EQ(s.nonManifoldEdges, 0u) << name(m);
    EXPECT_EQ(s.inconsistentEdges, 0u) << name(m);
    EXPECT_EQ(s.euler, 2) << name(m);
    EXPECT_NEAR(s.volume / truth, 1.0, 0.005) << name(m);
    EXPECT_FALSE(s.cellVolume.has_value()) << name(m);
    // Every vertex in the box; those flagged on a face exactly on it, and the caps there.
    std::array<int, 6> onFace{};
    for (std::size_t v = 0; v < x.mesh.positions.size(); ++v) {
      const Vec3f& p = x.mesh.positions[v];
      const float c[3] = {p.x, p.y, p.z};
      for (int a = 0; a < 3; ++a) {
        ASSERT_GE(c[a], 0.0f) << name(m);
        ASSERT_LE(c[a], 39.0f) << name(m);
        if (x.mesh.boundary[v] & (1u << (2 * a))) {
          ASSERT_EQ(c[a], 0.0f) << name(m);
          ++onFace[static_cast<std::size_t>(2 * a)];
        }
        if (x.mesh.boundary[v] & (1u << (2 * a + 1))) ++onFace[static_cast<std::size_t>(2 * a + 1)];
      }
      const Vec3f& n = x.mesh.normals[v];
      ASSERT_NEAR(std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z), 1.0, 1e-5) << name(m);
    }
    EXPECT_GT(onFace[0], 100) << name(m);  // x-min, y-min, z-min caps; the sphere misses the others
    EXPECT_GT(onFace[2], 100) << name(m);
    EXPECT_GT(onFace[4], 100) << name(m);
    EXPECT_EQ(onFace[1] + onFace[3] + onFace[5], 0) << name(m);
    const Extraction threaded = testing::extract(openSource(spec, {}), options, 3);
    EXPECT_TRUE(threaded.mesh == x.mesh) << name(m);
  }
}

// Without the caps the same sphere is open where the faces cut it; a sphere inside the volume is
// the same surface with or without them.
TEST(ExtractCloseBoundary, OnlyTheCutsChange) {
  ExtractOptions options;
  options.iso = 800;
  const Extraction open = testing::extract(openSource("phantom:sphere?n=40&r=20&c=5,6,7&field=distance", {}), options);
  EXPECT_GT(open.stats.boundaryEdges, 0u);
  EXPECT_EQ(open.stats.interiorBoundaryEdges, 0u);
  const char* inside = "phantom:sphere?n=40&r=12&field=distance";
  options.iso = 880;  // 1000 - 10 r
  const Extraction plain = testing::extract(openSource(inside, {}), options);
  options.closeBoundary = true;
  const Extraction capped = testing::extract(openSource(inside, {}), options);
  EXPECT_EQ(capped.mesh.triangles, plain.mesh.triangles);
  ASSERT_EQ(capped.mesh.positions.size(), plain.mesh.positions.size());
  for (std::size_t v = 0; v < plain.mesh.positions.size(); ++v) {
    EXPECT_NEAR(capped.mesh.positions[v].x, plain.mesh.positions[v].x, 1e-5);
    EXPECT_NEAR(capped.mesh.positions[v].y, plain.mesh.positions[v].y, 1e-5);
    EXPECT_NEAR(capped.mesh.positions[v].z, plain.mesh.positions[v].z, 1e-5);
  }
}

TEST(ExtractTorus, EulerCharacteristicZeroForEveryMethod) {
  for (Method m : kAllMethods) {
    const Extraction x = testing::extract("phantom:torus?n=64,64,32&R=18&r=7", m, 1000 - 70);
    EXPECT_TRUE(x.stats.closed()) << name(m);
    EXPECT_EQ(x.stats.inconsistentEdges, 0u) << name(m);
    EXPECT_EQ(x.stats.euler, 0) << name(m);
  }
}

// Random fields have every kind of cell, including every ambiguous face and, with few distinct
// values, many values exactly at iso.
TEST(ExtractRandom, NoCracksAndConsistentWinding) {
  for (unsigned seed : {1u, 2u, 3u, 4u}) {
    std::mt19937 rng(seed);
    const int levels = seed % 2 == 0 ? 4 : 1000;
    std::uniform_int_distribution<int> dist(0, levels - 1);
    std::vector<float> values(32 * 32 * 32);
    for (float& v : values) v = static_cast<float>(dist(rng));
    const double iso = levels / 2;
    for (Method m : kAllMethods) {
      testing::VectorSource source({32, 32, 32}, values);
      const Extraction x = testing::extract(source, m, iso);
      EXPECT_GT(x.stats.triangles, 1000u);
      EXPECT_EQ(x.stats.interiorBoundaryEdges, 0u) << name(m) << " seed " << seed;
      EXPECT_EQ(x.stats.nonManifoldEdges, 0u) << name(m) << " seed " << seed;
      EXPECT_EQ(x.stats.inconsistentEdges, 0u) << name(m) << " seed " << seed;
      if (x.stats.cellVolume) {
        // Closed or cut by the box, the per-tetrahedron volume stays within the box.
        EXPECT_GT(*x.stats.cellVolume, 0.0);
        EXPECT_LT(*x.stats.cellVolume, 31.0 * 31 * 31);
      }
    }
  }
}

TEST(ExtractRandom, EveryVertexIsUsedAndEveryIdIsDense) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> dist(0, 1);
  std::vector<float> values(20 * 17 * 13);
  for (float& v : values) v = dist(rng);
  for (Method m : kAllMethods) {
    testing::VectorSource source({20, 17, 13}, values);
    const Extraction x = testing::extract(source, m, 0.5);
    std::vector<int> uses(x.mesh.positions.size(), 0);
    for (const Triangle& t : x.mesh.triangles) {
      for (VertexId v : t) {
        ASSERT_LT(v, uses.size());
        ++uses[v];
      }
    }
    for (std::size_t v = 0; v < uses.size(); ++v) EXPECT_GT(uses[v], 0) << name(m) << " vertex " << v;
  }
}

TEST(ExtractRandom, CubeEdgeVerticesMatchMarchingCubesBitForBit) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> dist(0, 100);
  std::vector<float> values(24 * 24 * 24);
  for (float& v : values) v = dist(rng);
  auto key = [](const Vec3f& p) { return std::array<float, 3>{p.x, p.y, p.z}; };
  testing::VectorSource mcSource({24, 24, 24}, values);
  const Extraction mc = testing::extract(mcSource, Method::kMarchingCubes, 50);
  for (Method m : {Method::kTetra5, Method::kTetra6, Method::kBcc12, Method::kTetra24}) {
    testing::VectorSource source({24, 24, 24}, values);
    const Extraction x = testing::extract(source, m, 50);
    std::set<std::array<float, 3>> positions;
    for (const Vec3f& p : x.mesh.positions) positions.insert(key(p));
    for (const Vec3f& p : mc.mesh.positions) ASSERT_TRUE(positions.contains(key(p))) << name(m);
  }
}

TEST(ExtractStreaming, PhantomAndRawFileGiveIdenticalMeshes) {
  const std::string dir = testing::tempDir();
  const std::string spec = "phantom:head?n=40,44,36";
  auto phantom = openSource(spec, {});
  VolumeWriteOptions i16;
  i16.type = VoxelType::kI16;
  writeVolume(*phantom, dir + "/head.raw", i16);
  for (Method m : kAllMethods) {
    const Extraction a = testing::extract(spec, m, -400, true);
    SourceOptions options;
    options.raw = RawOptions{};
    options.raw->dims = {40, 44, 36};
    options.raw->type = VoxelType::kI16;
    auto raw = openSource(dir + "/head.raw", options);
    const Extraction b = testing::extract(*raw, m, -400, true);
    EXPECT_GT(a.mesh.triangles.size(), 1000u);
    EXPECT_TRUE(a.mesh == b.mesh) << name(m);
  }
}

TEST(ExtractNormals, PointOutOfTheSphere) {
  for (Method m : kAllMethods) {
    const Extraction x = testing::extract("phantom:sphere?n=40&r=12", m, 880, true);
    ASSERT_EQ(x.mesh.normals.size(), x.mesh.positions.size());
    const double c = 19.5;
    for (std::size_t v = 0; v < x.mesh.positions.size(); ++v) {
      const Vec3f& p = x.mesh.positions[v];
      const Vec3f& n = x.mesh.normals[v];
      const double dx = p.x - c, dy = p.y - c, dz = p.z - c;
      const double len = std::sqrt(dx * dx + dy * dy + dz * dz);
      EXPECT_GT((n.x * dx + n.y * dy + n.z * dz) / len, 0.99) << name(m);
      EXPECT_NEAR(std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z), 1.0, 1e-5);
    }
  }
}

TEST(ExtractFrame, LeftHandedFrameKeepsNormalsOutward) {
  // Flip the y axis: the frame is left-handed, so winding must be reversed for the enclosed
  // volume (and the triangles' facing) to stay positive.
  auto field = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = static_cast<double>(i) - 12, y = static_cast<double>(j) - 12, z = static_cast<double>(k) - 12;
    return static_cast<float>(1000 - 10 * std::sqrt(x * x + y * y + z * z));
  };
  for (Method m : kAllMethods) {
    testing::VectorSource source({25, 25, 25}, field);
    source.mutableInfo().direction = {1, 0, 0, 0, -1, 0, 0, 0, 1};
    source.mutableInfo().spacing = {0.5, 0.5, 2.0};
    const Extraction x = testing::extract(source, m, 920, true);
    const double volume = 4.0 / 3.0 * std::numbers::pi * 8 * 8 * 8 * 0.5 * 0.5 * 2.0;
    EXPECT_NEAR(x.stats.volume / volume, 1.0, 0.02) << name(m);
    EXPECT_EQ(x.stats.inconsistentEdges, 0u);
    if (x.stats.cellVolume) {
      EXPECT_NEAR(*x.stats.cellVolume / x.stats.volume, 1.0, 1e-6);
    }
    // Normals agree with the facing of their triangles (by area: slivers may disagree).
    double agree = 0;
    double total = 0;
    for (const Triangle& t : x.mesh.triangles) {
      const Vec3f& a = x.mesh.positions[t[0]];
      const Vec3f& b = x.mesh.positions[t[1]];
      const Vec3f& c = x.mesh.positions[t[2]];
      const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z, vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
      const double n[3] = {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
      const Vec3f& na = x.mesh.normals[t[0]];
      const double twiceArea = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      total += twiceArea;
      agree += n[0] * na.x + n[1] * na.y + n[2] * na.z > 0 ? twiceArea : 0;
    }
    EXPECT_GT(agree / total, 0.999) << name(m);
  }
}

TEST(ExtractFrame, PhysicalFramePlacesVerticesByOriginDirectionAndSpacing) {
  testing::VectorSource source({4, 4, 4},
                               [](std::int64_t i, std::int64_t, std::int64_t) { return static_cast<float>(i); });
  VolumeInfo& info = source.mutableInfo();
  info.origin = {10, 20, 30};
  info.spacing = {2, 3, 4};
  info.direction = {0, 1, 0, 1, 0, 0, 0, 0, 1};  // i runs along y, j along x
  const Extraction x = testing::extract(source, Method::kMarchingCubes, 1.5);
  ASSERT_FALSE(x.mesh.positions.empty());
  for (const Vec3f& p : x.mesh.positions) {
    EXPECT_FLOAT_EQ(p.y, 20 + 1.5f * 2);  // the plane i = 1.5
  }
}

TEST(ExtractSliceOrigins, UnevenSlicesPutVerticesInTheirSlicesPlanes) {
  // The field varies along k too, so that vertices lie on the edges between slices as well.
  testing::VectorSource source({6, 6, 4}, [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = static_cast<double>(i) - 2.5, y = static_cast<double>(j) - 2.5;
    return static_cast<float>(x * x + y * y + 2.0 * static_cast<double>(k));
  });
  const std::vector<std::array<double, 3>> origins{{0, 0, 0}, {0, 0.5, 4}, {0, 1, 5}, {0, 1.5, 12}};
  source.mutableInfo().sliceOrigins = origins;
  const Extraction x = testing::extract(source, Method::kMarchingCubes, 9.0);
  auto integral = [](double v) { return std::abs(v - std::round(v)) < 1e-4; };
  std::set<float> zs;
  std::size_t between = 0;
  for (const Vec3f& p : x.mesh.positions) {
    std::size_t k = 0;
    while (k + 2 < origins.size() && p.z > origins[k + 1][2]) ++k;
    const double t = (p.z - origins[k][2]) / (origins[k + 1][2] - origins[k][2]);
    ASSERT_GE(t, -1e-6) << p.z;
    ASSERT_LE(t, 1 + 1e-6) << p.z;
    if (t < 1e-6 || t > 1 - 1e-6) {
      // In slice k or k + 1: on an x edge (y offset from the slice's origin whole) or a y edge.
      const auto& o = origins[t < 0.5 ? k : k + 1];
      zs.insert(p.z);
      EXPECT_TRUE(integral(p.x) || integral(p.y - o[1])) << p.x << "," << p.y << "," << p.z;
    } else {
      // On an edge from slice k to k + 1: (i, j) whole, y offset by the interpolated origin.
      ++between;
      const double y0 = origins[k][1] + t * (origins[k + 1][1] - origins[k][1]);
      EXPECT_TRUE(integral(p.x) && integral(p.y - y0)) << p.x << "," << p.y << "," << p.z;
    }
  }
  EXPECT_EQ(zs, (std::set<float>{0, 4, 5, 12}));
  // x^2 + y^2 takes the values 0.5 (4 points), 2.5 (8), 4.5 (4), 6.5 (8), 8.5 (8), ...: the k edges
  // cross 9 where it lies in (7, 9), (5, 7) and (3, 5), so at 8 + 8 + 4 points.
  EXPECT_EQ(between, 20u);
}

// --roi-space physical: the lattice box of the points inside a box equals the one found by testing
// every lattice point, for an axis-aligned frame (whose answer is worked out by hand), for a
// rotated one, and for tilted, unevenly spaced slices.
TEST(ExtractFrame, LatticeBoxHoldsExactlyThePointsInsideTheBox) {
  const std::array<std::int64_t, 3> dims{30, 25, 20};
  auto bruteForce = [&](const LatticeFrame& frame, const std::array<double, 6>& box) {
    std::optional<LatticeBox> found;
    for (std::int64_t k = 0; k < dims[2]; ++k)
      for (std::int64_t j = 0; j < dims[1]; ++j)
        for (std::int64_t i = 0; i < dims[0]; ++i) {
          const Vec3d p = frame.map(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
          if (!(box[0] <= p[0] && p[0] <= box[3] && box[1] <= p[1] && p[1] <= box[4] && box[2] <= p[2] &&
                p[2] <= box[5]))
            continue;
          if (!found) found = LatticeBox{{i, j, k}, {i, j, k}};
          found->lo = {std::min(found->lo[0], i), std::min(found->lo[1], j), std::min(found->lo[2], k)};
          found->hi = {std::max(found->hi[0], i), std::max(found->hi[1], j), std::max(found->hi[2], k)};
        }
    return found;
  };
  VolumeInfo info;
  info.dims = dims;
  info.origin = {-3, 1, 10};
  info.spacing = {0.5, 0.75, 2};
  const LatticeFrame aligned = LatticeFrame::physical(info);
  // x = -3 + 0.5 i: 2.1 .. 7 gives i = 11 .. 20 (7 exactly on a point); y = 1 + 0.75 j: -50 .. 5.5
  // gives j = 0 .. 6; z = 10 + 2 k: 13 .. 99 gives k = 2 .. 19.
  EXPECT_EQ(aligned.latticeBox({2.1, -50, 13, 7, 5.5, 99}, dims), (LatticeBox{{11, 0, 2}, {20, 6, 19}}));
  EXPECT_EQ(aligned.latticeBox({2.1, -50, 13, 2.4, 5.5, 99}, dims), std::nullopt);  // between two points
  EXPECT_EQ(aligned.latticeBox({100, 0, 0, 200, 1, 1}, dims), std::nullopt);
  // The voxel frame: a box of indices, rounded inwards.
  EXPECT_EQ(LatticeFrame::voxel().latticeBox({-0.5, 2.5, 3, 4, 7.99, 1e9}, dims), (LatticeBox{{0, 3, 3}, {4, 7, 19}}));

  VolumeInfo rotated = info;
  const double c = std::cos(0.3), s = std::sin(0.3);
  rotated.direction = {c, -s, 0, s, c, 0, 0, 0, 1};
  VolumeInfo tilted = info;
  tilted.direction = {1, 0, 0, 0, 0.948, -0.317, 0, 0.317, 0.948};
  for (std::int64_t k = 0; k < dims[2]; ++k) {
    const double z = 2.0 * static_cast<double>(k) + (k > 12 ? 3.5 : 0);  // one wider gap
    tilted.sliceOrigins.push_back({-3, 1 - 0.317 * z * 0.3, 10 + z});
  }
  std::mt19937 random(17);
  std::uniform_real_distribution<double> coordinate(-15, 45);
  for (const VolumeInfo& frameInfo : {info, rotated, tilted}) {
    const LatticeFrame frame = LatticeFrame::physical(frameInfo);
    int nonEmpty = 0;
    for (int n = 0; n < 200; ++n) {
      std::array<double, 6> box{};
      for (std::size_t a = 0; a < 3; ++a) {
        box[a] = coordinate(random);
        box[a + 3] = coordinate(random);
        if (box[a] > box[a + 3]) std::swap(box[a], box[a + 3]);
      }
      const auto expected = bruteForce(frame, box);
      nonEmpty += expected.has_value();
      ASSERT_EQ(frame.latticeBox(box, dims), expected) << n;
    }
    EXPECT_GT(nonEmpty, 50);
  }
}

// A single voxel of 1 among zeros, at iso 1: every vertex lies on the voxel itself, where the
// central differences cancel. The fallback (the one-sided difference along the vertex's edge) must
// give unit normals pointing out of the voxel along its edges: for mc, exactly the six axis
// directions, once each; for the tetrahedral methods, unit length and pointing away from the voxel.
TEST(Normals, UnitWhereTheCentralDifferenceVanishes) {
  for (const Method method : kAllMethods) {
    testing::VectorSource source({5, 5, 5}, [](std::int64_t x, std::int64_t y, std::int64_t z) {
      return x == 2 && y == 2 && z == 2 ? 1.0f : 0.0f;
    });
    source.mutableInfo().spacing = {1, 2, 3};
    const Extraction x = testing::extract(source, method, 1.0, true);
    ASSERT_FALSE(x.mesh.normals.empty()) << name(method);
    ASSERT_EQ(x.mesh.normals.size(), x.mesh.positions.size());
    std::multiset<std::array<float, 3>> directions;
    for (std::size_t v = 0; v < x.mesh.normals.size(); ++v) {
      const Vec3f& n = x.mesh.normals[v];
      const Vec3f& p = x.mesh.positions[v];
      EXPECT_NEAR(std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z), 1.0, 1e-6) << name(method) << " vertex " << v;
      // Vertices on the voxel's edges point along them, away from the voxel (2, 4, 6).
      const std::array<double, 3> out{p.x - 2.0, p.y - 4.0, p.z - 6.0};
      if (out[0] * out[0] + out[1] * out[1] + out[2] * out[2] == 0) {
        directions.insert({n.x, n.y, n.z});
      } else {
        EXPECT_GT(n.x * out[0] + n.y * out[1] + n.z * out[2], 0) << name(method) << " vertex " << v;
      }
    }
    if (method == Method::kMarchingCubes || method == Method::kMarchingCubes33) {
      EXPECT_EQ(x.mesh.positions.size(), 6u);
      EXPECT_EQ(directions, (std::multiset<std::array<float, 3>>{
                                {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}));
    }
  }
}

// The MRI brain template that showed 45 zero-length normals at iso 103.5 (Debian's mricron-data).
TEST(Normals, EveryNormalOfABrainIsUnitLength) {
  const std::string brain = "/usr/share/mricron/templates/ch2better.nii.gz";
  if (testing::slurp(brain).empty()) GTEST_SKIP() << brain << " is absent (Debian's mricron-data)";
  const Extraction x = testing::extract(brain, Method::kMarchingCubes, 103.5, true);
  ASSERT_GT(x.mesh.normals.size(), 100000u);
  std::size_t bad = 0;
  for (const Vec3f& n : x.mesh.normals) {
    if (!(std::abs(std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z) - 1.0) < 1e-5)) ++bad;
  }
  EXPECT_EQ(bad, 0u);
}

// Found by tests/fuzz/fuzz_extract: an infinite value at one end of a crossed edge, an infinite iso
// value, or a NaN (outside) end left NaN in the interpolation, which gave NaN vertices and normals.
TEST(FuzzRegressions, InfiniteAndNaNValuesGiveFiniteVerticesOnTheirEdges) {
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  struct Volume {
    float inside, outside, other;
    double iso;
  };
  for (const Volume& v :
       {Volume{inf, 0, -inf, 0.5}, Volume{inf, 1, 2, inf}, Volume{5, nan, 0, 1}, Volume{inf, -inf, nan, -inf}}) {
    auto field = [&v](std::int64_t i, std::int64_t j, std::int64_t k) {
      if (i == 2 && j == 2 && k == 2) return v.inside;
      return (i + j + k) % 5 == 0 ? v.other : v.outside;
    };
    for (Method m : kAllMethods) {
      testing::VectorSource source({5, 5, 5}, field);
      const Extraction x = testing::extract(source, m, v.iso, true);
      for (const Vec3f& p : x.mesh.positions) {
        ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) << name(m) << " iso " << v.iso;
        EXPECT_TRUE(p.x >= 0 && p.x <= 4 && p.y >= 0 && p.y <= 4 && p.z >= 0 && p.z <= 4) << name(m);
      }
      for (const Vec3f& n : x.mesh.normals) {
        ASSERT_TRUE(std::isfinite(n.x) && std::isfinite(n.y) && std::isfinite(n.z)) << name(m) << " iso " << v.iso;
      }
      EXPECT_EQ(x.stats.nonManifoldEdges, 0u) << name(m);
      EXPECT_EQ(x.stats.interiorBoundaryEdges, 0u) << name(m);
    }
  }
}

// Found by tests/fuzz/fuzz_extract: in a volume two points wide, bcc12 marched the one cell of each
// interior row twice (as the row's first and as its last boundary cell): every triangle doubled.
TEST(FuzzRegressions, Bcc12OnAVolumeTwoPointsWideIsClosed) {
  auto block = [](std::int64_t, std::int64_t j, std::int64_t k) {
    return j >= 2 && j <= 3 && k >= 2 && k <= 4 ? 1.0f : 0.0f;
  };
  for (Method m : kAllMethods) {
    testing::VectorSource source({2, 7, 7}, block);
    const Extraction x = testing::extract(source, m, 0.5);
    EXPECT_GT(x.stats.triangles, 0u) << name(m);
    EXPECT_EQ(x.stats.nonManifoldEdges, 0u) << name(m);
    EXPECT_EQ(x.stats.inconsistentEdges, 0u) << name(m);
    EXPECT_EQ(x.stats.interiorBoundaryEdges, 0u) << name(m);
  }
}

}  // namespace
}  // namespace isoslab

// The extraction kernels on their own: core/ and extract/ with nothing else of isoslab (no reader,
// no pipeline, no writer), so that this binary builds with only a compiler, CMake and GoogleTest
// (-DISOSLAB_KERNELS_ONLY=ON). Slabs are fed by hand; references are brute-force computations.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include "extract/extractor.h"
#include "extract/frame.h"
#include "extract/slab_stitcher.h"
#include "extract/tet_volume.h"

namespace isoslab {
namespace {

using Field = std::function<float(std::int64_t, std::int64_t, std::int64_t)>;

struct Volume {
  std::array<std::int64_t, 3> dims{};
  std::vector<std::vector<float>> slices;

  Volume(std::array<std::int64_t, 3> d, const Field& f) : dims(d) {
    for (std::int64_t k = 0; k < dims[2]; ++k) {
      std::vector<float> s;
      for (std::int64_t j = 0; j < dims[1]; ++j) {
        for (std::int64_t i = 0; i < dims[0]; ++i) s.push_back(f(i, j, k));
      }
      slices.push_back(std::move(s));
    }
  }
  bool inside(std::int64_t i, std::int64_t j, std::int64_t k, double iso) const {
    return slices[static_cast<std::size_t>(k)][static_cast<std::size_t>(j * dims[0] + i)] >= iso;
  }
  SlabView view(std::int64_t z) const {
    SlabView v;
    v.z = z;
    v.dims = dims;
    for (std::int64_t d = -1; d <= 2; ++d) {
      const std::int64_t k = z + d;
      if (k >= 0 && k < dims[2]) v.slices[static_cast<std::size_t>(d + 1)] = slices[static_cast<std::size_t>(k)].data();
    }
    return v;
  }
  VolumeInfo info() const {
    VolumeInfo i;
    i.dims = dims;
    return i;
  }
};

struct Mesh {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
  std::vector<MeshChunk> chunks;
};

ExtractOptions options(Method m, double iso, bool normals = true) {
  ExtractOptions o;
  o.method = m;
  o.iso = iso;
  o.normals = normals;
  return o;
}

Mesh sequential(const Volume& vol, const ExtractOptions& o) {
  auto ex = makeExtractor(o, vol.info(), LatticeFrame::voxel());
  Mesh mesh;
  for (std::int64_t z = 0; z + 1 < vol.dims[2]; ++z) {
    MeshChunk chunk;
    chunk.slab = z;
    chunk.firstVertex = static_cast<VertexId>(ex->vertexCount());
    ex->extractSlab(vol.view(z), chunk);
    mesh.positions.insert(mesh.positions.end(), chunk.positions.begin(), chunk.positions.end());
    mesh.triangles.insert(mesh.triangles.end(), chunk.triangles.begin(), chunk.triangles.end());
    mesh.chunks.push_back(std::move(chunk));
  }
  return mesh;
}

// A sphere of radius r around the volume's centre, well inside it.
Field sphere(std::array<std::int64_t, 3> dims, double r) {
  return [=](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = static_cast<double>(i) - 0.5 * static_cast<double>(dims[0] - 1) + 0.13;
    const double y = static_cast<double>(j) - 0.5 * static_cast<double>(dims[1] - 1) - 0.07;
    const double z = static_cast<double>(k) - 0.5 * static_cast<double>(dims[2] - 1) + 0.21;
    return static_cast<float>(r - std::sqrt(x * x + y * y + z * z));
  };
}

// Every undirected edge is used by exactly two triangles, once in each direction: a closed,
// consistently oriented surface.
void expectClosedAndOriented(const Mesh& m, const std::string& what) {
  std::map<std::pair<VertexId, VertexId>, int> directed;
  for (const Triangle& t : m.triangles) {
    for (VertexId v : t) ASSERT_LT(v, m.positions.size()) << what;
    ASSERT_TRUE(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) << what;
    for (int e = 0; e < 3; ++e) ++directed[{t[static_cast<std::size_t>(e)], t[static_cast<std::size_t>((e + 1) % 3)]}];
  }
  for (const auto& [edge, count] : directed) {
    ASSERT_EQ(count, 1) << what << ": edge " << edge.first << "-" << edge.second << " used twice in one direction";
    ASSERT_EQ(directed.count({edge.second, edge.first}), 1u)
        << what << ": boundary edge " << edge.first << "-" << edge.second;
  }
}

TEST(Kernels, SphereSurfacesAreClosedAndOriented) {
  const std::array<std::int64_t, 3> dims{13, 12, 11};
  const Volume vol(dims, sphere(dims, 4.2));
  for (Method m : kMethods) {
    const Mesh mesh = sequential(vol, options(m, 0.0));
    EXPECT_GT(mesh.triangles.size(), 100u) << methodName(m);
    expectClosedAndOriented(mesh, std::string(methodName(m)));
  }
}

// Marching Cubes makes one vertex per axis-aligned lattice edge whose ends differ: counted here by
// brute force over every edge of the lattice.
TEST(Kernels, MarchingCubesHasOneVertexPerCutLatticeEdge) {
  const std::array<std::int64_t, 3> dims{9, 10, 8};
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> values;
  for (int n = 0; n < 9 * 10 * 8; ++n) values.push_back(u(rng));
  const Volume vol(dims, [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return values[static_cast<std::size_t>((k * 10 + j) * 9 + i)];
  });
  for (double iso : {0.3, 0.5, 0.8}) {
    std::size_t cut = 0;
    for (std::int64_t k = 0; k < dims[2]; ++k) {
      for (std::int64_t j = 0; j < dims[1]; ++j) {
        for (std::int64_t i = 0; i < dims[0]; ++i) {
          const bool in = vol.inside(i, j, k, iso);
          if (i + 1 < dims[0] && vol.inside(i + 1, j, k, iso) != in) ++cut;
          if (j + 1 < dims[1] && vol.inside(i, j + 1, k, iso) != in) ++cut;
          if (k + 1 < dims[2] && vol.inside(i, j, k + 1, iso) != in) ++cut;
        }
      }
    }
    const Mesh mesh = sequential(vol, options(Method::kMarchingCubes, iso));
    EXPECT_EQ(mesh.positions.size(), cut) << "iso " << iso;
    std::set<std::tuple<float, float, float>> distinct;
    for (const Vec3f& p : mesh.positions) distinct.insert({p.x, p.y, p.z});
    EXPECT_EQ(distinct.size(), cut) << "welded: no two vertices at one place";
  }
}

// A cube edge gets the same vertex position under every method: each Marching Cubes vertex is also
// a vertex of every tetrahedral method, bit for bit.
TEST(Kernels, CubeEdgeVerticesAgreeAcrossMethods) {
  const std::array<std::int64_t, 3> dims{11, 11, 11};
  const Volume vol(dims, sphere(dims, 3.7));
  const Mesh mc = sequential(vol, options(Method::kMarchingCubes, 0.0));
  for (Method m : {Method::kTetra5, Method::kTetra6, Method::kBcc12, Method::kTetra24, Method::kMarchingCubes33}) {
    const Mesh other = sequential(vol, options(m, 0.0));
    std::set<std::tuple<float, float, float>> have;
    for (const Vec3f& p : other.positions) have.insert({p.x, p.y, p.z});
    for (const Vec3f& p : mc.positions) {
      ASSERT_TRUE(have.count({p.x, p.y, p.z})) << methodName(m) << " lacks " << p.x << "," << p.y << "," << p.z;
    }
  }
}

// Slab workers extract runs of slabs in any order; stitched in slab order they give the sequential
// extractor's chunks exactly, ids included, however the slabs are cut into runs (here runs of 1 to
// 4 slabs, in an order that is not the slabs', by one worker reused for all).
TEST(Kernels, StitchedWorkerPartsEqualTheSequentialChunks) {
  const std::array<std::int64_t, 3> dims{10, 9, 12};
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const Volume vol(dims, [&](std::int64_t, std::int64_t, std::int64_t) { return u(rng); });
  const std::vector<std::int64_t> runStarts{0, 1, 3, 7, 8};  // runs of 1, 2, 4, 1 and 3 slabs
  for (Method m : kMethods) {
    const ExtractOptions o = options(m, 0.5);
    const Mesh want = sequential(vol, o);
    auto ex = makeExtractor(o, vol.info(), LatticeFrame::voxel());
    std::vector<SlabPart> parts(runStarts.size());
    auto worker = ex->makeWorker();
    for (std::size_t r = runStarts.size(); r-- > 0;) {
      const std::int64_t end = r + 1 < runStarts.size() ? runStarts[r + 1] : dims[2] - 1;
      std::vector<SlabView> views;
      for (std::int64_t z = runStarts[r]; z < end; ++z) views.push_back(vol.view(z));
      worker->extract(views, parts[r], {});
    }
    SlabStitcher stitcher(ex->sliceSlots());
    std::vector<MeshChunk> chunks;
    for (SlabPart& part : parts) {
      stitcher.stitch(part);
      for (MeshChunk& c : part.chunks) chunks.push_back(c);
    }
    ASSERT_EQ(chunks.size(), want.chunks.size());
    for (std::size_t z = 0; z < chunks.size(); ++z) {
      const MeshChunk& got = chunks[z];
      const MeshChunk& exp = want.chunks[z];
      EXPECT_EQ(got.slab, exp.slab) << methodName(m) << " slab " << z;
      EXPECT_EQ(got.firstVertex, exp.firstVertex) << methodName(m) << " slab " << z;
      EXPECT_EQ(got.positions, exp.positions) << methodName(m) << " slab " << z;
      EXPECT_EQ(got.normals, exp.normals) << methodName(m) << " slab " << z;
      EXPECT_EQ(got.boundary, exp.boundary) << methodName(m) << " slab " << z;
      EXPECT_EQ(got.triangles, exp.triangles) << methodName(m) << " slab " << z;
      EXPECT_EQ(got.cellVolume, exp.cellVolume) << methodName(m) << " slab " << z;
    }
  }
}

// The inside part of a tetrahedron against counting a fine barycentric sample of it.
TEST(Kernels, TetInsideVolumeMatchesSampling) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  constexpr int kSteps = 120;
  for (int trial = 0; trial < 30; ++trial) {
    std::array<double, 4> v{};
    for (double& x : v) x = u(rng);
    const double iso = 0.5;
    unsigned cas = 0;
    for (unsigned k = 0; k < 4; ++k) cas |= static_cast<unsigned>(v[k] >= iso) << k;
    if (cas == 0 || cas == 15) continue;
    // Midpoints of a regular subdivision of the barycentric simplex, each of equal weight.
    std::int64_t in = 0;
    std::int64_t all = 0;
    for (int a = 0; a < kSteps; ++a) {
      for (int b = 0; a + b < kSteps; ++b) {
        for (int c = 0; a + b + c < kSteps; ++c) {
          const double la = (a + 0.25) / kSteps, lb = (b + 0.25) / kSteps, lc = (c + 0.25) / kSteps;
          const double ld = 1.0 - la - lb - lc;
          if (ld <= 0) continue;
          ++all;
          if (la * v[0] + lb * v[1] + lc * v[2] + ld * v[3] >= iso) ++in;
        }
      }
    }
    const double sampled = static_cast<double>(in) / static_cast<double>(all);
    EXPECT_NEAR(tetInsideVolume(v, 1.0, cas, iso), sampled, 0.02) << "trial " << trial << " case " << cas;
  }
}

// Kernels allocate, so they must be able to throw std::bad_alloc to the caller.
static_assert(!noexcept(std::declval<Extractor&>().extractSlab(std::declval<const SlabView&>(),
                                                               std::declval<MeshChunk&>())));
static_assert(
    !noexcept(std::declval<SlabWorker&>().extract(std::declval<std::span<const SlabView>>(), std::declval<SlabPart&>(),
                                                  std::declval<const std::function<void(const SlabView&)>&>())));

}  // namespace
}  // namespace isoslab

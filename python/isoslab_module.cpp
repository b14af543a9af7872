// isoslab._isoslab: the library from NumPy (issue 21). The Python package (python/isoslab/
// __init__.py) gives the public functions and their argument checks; this module does the work,
// with the GIL released while it extracts or reads.
//
// Axes: a C-ordered array volume[a0, a1, a2] is a lattice whose x (fastest) is a2, y is a1 and z
// (the slices) is a0, so each volume[k] is one slice, lent in place when the array is float32 and
// C-contiguous. Vertices come back in array index order (a0, a1, a2), as scikit-image gives them.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <sys/mman.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "encode/indexed_mesh.h"
#include "extract/extractor.h"
#include "extract/frame.h"
#include "io/open_source.h"
#include "metrics/components.h"
#include "metrics/mesh_stats.h"
#include "metrics/report.h"
#include "metrics/sphere_metrics.h"
#include "python/array_source.h"
#include "python/extract_binding.h"
#include "stream/pipeline.h"
#include "stream/value_range.h"

namespace py = pybind11;

namespace isoslab {
namespace {

std::array<double, 2> volumeRange(const py::array& volume) {
  ArraySource source(volume);
  std::optional<std::array<double, 2>> r;
  {
    py::gil_scoped_release release;
    r = source.range();
  }
  if (!r) return {std::nan(""), std::nan("")};
  return *r;
}

// A growing array of T in pages of its own (mmap), grown by mremap, which moves pages instead of
// copying them: the mesh is never held twice, and no time goes to copies. Handed to NumPy
// without a copy; the array's capsule unmaps it.
template <typename T>
class GrowBuffer {
 public:
  GrowBuffer() = default;
  GrowBuffer(const GrowBuffer&) = delete;
  GrowBuffer& operator=(const GrowBuffer&) = delete;
  ~GrowBuffer() {
    if (data_ != nullptr) ::munmap(data_, bytes_);
  }

  T* extend(std::size_t n) {
    if ((size_ + n) * sizeof(T) > bytes_) {
      // Huge pages where the system gives them on request (madvise): a page fault per 2 MiB
      // instead of per 4 KiB, which on a virtual machine is most of the time of filling them.
      const std::size_t page = std::size_t{1} << 21;
      const std::size_t want = std::max((size_ + n) * sizeof(T), bytes_ + bytes_ / 2);
      const std::size_t bytes = (want + page - 1) / page * page;
      void* p = data_ == nullptr ? ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0)
                                 : ::mremap(data_, bytes_, bytes, MREMAP_MAYMOVE);
      if (p == MAP_FAILED) throw std::bad_alloc();
      ::madvise(p, bytes, MADV_HUGEPAGE);  // advice only: no error if the system has none
      data_ = static_cast<T*>(p);
      bytes_ = bytes;
    }
    T* out = data_ + size_;
    size_ += n;
    return out;
  }

  std::size_t size() const noexcept { return size_; }

  // A NumPy array of shape (size / columns, columns) (or (size,) for columns 0) that owns the data.
  py::array release(py::ssize_t columns) {
    if (data_ == nullptr) extend(0);
    struct Mapping {
      void* data;
      std::size_t bytes;
    };
    auto* mapping = new Mapping{data_, bytes_};
    py::capsule unmap(mapping, [](void* q) {
      auto* m = static_cast<Mapping*>(q);
      ::munmap(m->data, m->bytes);
      delete m;
    });
    T* owned = data_;
    const auto n = static_cast<py::ssize_t>(size_);
    data_ = nullptr;
    bytes_ = 0;
    size_ = 0;
    if (columns == 0) return py::array_t<T>({n}, owned, unmap);
    return py::array_t<T>({n / columns, columns}, owned, unmap);
  }

 private:
  T* data_ = nullptr;
  std::size_t size_ = 0;
  std::size_t bytes_ = 0;
};

// Streams the chunks into scikit-image's arrays as they come: vertices in array index order and
// scaled, normals likewise, faces in the winding asked for, and each vertex's value (the largest
// value span of a cell around it).
class ArraySink final : public MeshSink {
 public:
  ArraySink(const ArraySource& source, const std::array<double, 3>& spacing, double level, bool ascent)
      : source_(source), lent_(source.lentData()), spacing_(spacing), level_(level), ascent_(ascent) {}

  void begin(const MeshHeader&) override {}
  void consume(const MeshChunk& c) override {
    const std::size_t n = c.positions.size();
    float* v = verts.extend(3 * n);
    float* nn = normals.extend(3 * n);
    float* val = values.extend(n);
    for (std::size_t k = 0; k < n; ++k) {
      const Vec3f& p = c.positions[k];
      v[3 * k] = static_cast<float>(p.z * spacing_[0]);
      v[3 * k + 1] = static_cast<float>(p.y * spacing_[1]);
      v[3 * k + 2] = static_cast<float>(p.x * spacing_[2]);
      const Vec3f& q = c.normals[k];
      nn[3 * k] = q.z;
      nn[3 * k + 1] = q.y;
      nn[3 * k + 2] = q.x;
    }
    for (std::size_t k = 0; k < n; ++k) val[k] = valueAt(c.positions[k]);
    // Reversing the axes mirrors the mesh, which reverses the winding: isoslab's (counter-clockwise
    // from the lower values) becomes scikit-image's "descent" order; "ascent" reverses it back.
    std::int32_t* f = faces.extend(3 * c.triangles.size());
    for (const Triangle& t : c.triangles) {
      *f++ = static_cast<std::int32_t>(t[0]);
      *f++ = static_cast<std::int32_t>(ascent_ ? t[2] : t[1]);
      *f++ = static_cast<std::int32_t>(ascent_ ? t[1] : t[2]);
    }
  }
  void finish() override {}

  GrowBuffer<float> verts, normals, values;
  GrowBuffer<std::int32_t> faces;

 private:
  // Four floats and two doubles, in the compiler's vector types (SSE registers on x86-64).
  using Floats4 = float __attribute__((vector_size(16)));
  using Doubles2 = double __attribute__((vector_size(16)));

  // The larger and the smaller of two, as std::max and std::min give them, but by value (and
  // lane by lane for vectors): the compiler makes them maxss / minss (maxps ...) instead of
  // branches.
  template <typename T>
  static T larger(T a, T b) noexcept {
    return a < b ? b : a;
  }
  template <typename T>
  static T smaller(T a, T b) noexcept {
    return b < a ? b : a;
  }

  // scikit-image's value of a vertex: the largest span (max - min, the level between) of the
  // values of a cell around it. A vertex lies on a lattice edge or diagonal; its cells are those
  // whose closed box holds it (at most 8, for a vertex on a lattice point).
  float valueAt(const Vec3f& p) const noexcept {
    if (lent_ != nullptr) {
      if (const auto value = edgeValue(p)) return *value;
    }
    return anyValueAt(p);
  }

  // valueAt's common case, from the lent floats: a vertex inside a lattice edge (one coordinate
  // between two lattice points, the others on one) that is not on the volume's faces. Its four
  // cells are the 2 x 2 around the edge, read as nine voxel pairs along it (18 voxels). Nothing
  // for any other vertex, or when one of the voxels is NaN. The same extremes as anyValueAt
  // (found in another order), four lanes at a time and without a branch on the values (they
  // would be mispredicted half the time).
  std::optional<float> edgeValue(const Vec3f& p) const noexcept {
    const auto& d = source_.info().dims;  // x, y, z
    // Truncation is the floor: the vertices are inside the lattice (not negative).
    const auto x = static_cast<std::int64_t>(p.x), y = static_cast<std::int64_t>(p.y),
               z = static_cast<std::int64_t>(p.z);
    const bool inX = static_cast<float>(x) != p.x, inY = static_cast<float>(y) != p.y,
               inZ = static_cast<float>(z) != p.z;  // the coordinate between two lattice points
    if (inX + inY + inZ != 1) return std::nullopt;  // on a lattice point or a diagonal
    // On the edge's axis, 0 <= floor <= d - 2; on the others (a cell each side), 1 <= c <= d - 2.
    const auto outside = [](std::int64_t c, bool in, std::int64_t n) { return c < !in || c > n - 2; };
    if (outside(x, inX, d[0]) || outside(y, inY, d[1]) || outside(z, inZ, d[2])) return std::nullopt;
    const std::int64_t sy = d[0], sz = d[0] * d[1];
    const std::int64_t s = inX ? 1 : inY ? sy : sz;  // the stride along the edge
    const std::int64_t u = inX ? sy : 1;             // and the two across it
    const std::int64_t w = inZ ? sy : sz;
    const float* q = lent_ + x + y * sy + z * sz - u - w;
    // Per row b across w: lanes a = 0, 1, 2 across u (and 2 again), the smaller and larger of
    // each pair along the edge.
    std::array<Floats4, 3> lo, hi;
    Floats4 sum{0, 0, 0, 0};
    for (std::size_t b = 0; b < 3; ++b) {
      const float* r = q + static_cast<std::int64_t>(b) * w;
      const Floats4 first{r[0], r[u], r[2 * u], r[2 * u]};
      const Floats4 second{r[s], r[u + s], r[2 * u + s], r[2 * u + s]};
      lo[b] = smaller(first, second);
      hi[b] = larger(first, second);
      sum += first + second;
    }
    // With a NaN among the voxels, smaller() and larger() would keep or drop it by its place in
    // the pair, where anyValueAt skips it: that case goes to anyValueAt. (A NaN sum can also come
    // from infinities, which anyValueAt then handles as well.)
    const float total = sum[0] + sum[1] + sum[2] + sum[3];
    if (std::isnan(total)) return std::nullopt;
    // The cells: rows b, b + 1 (one vector per b), then lanes a, a + 1 (lanes 0 and 1).
    std::array<Floats4, 2> bottom{smaller(lo[0], lo[1]), smaller(lo[1], lo[2])};
    std::array<Floats4, 2> top{larger(hi[0], hi[1]), larger(hi[1], hi[2])};
    const Doubles2 level{level_, level_}, zero{0, 0};
    Doubles2 best = zero;
    for (std::size_t b = 0; b < 2; ++b) {
      bottom[b] = smaller(bottom[b], __builtin_shufflevector(bottom[b], bottom[b], 1, 2, 3, 3));
      top[b] = larger(top[b], __builtin_shufflevector(top[b], top[b], 1, 2, 3, 3));
      // As anyValueAt, in double.
      const Doubles2 t = __builtin_convertvector(__builtin_shufflevector(top[b], top[b], 0, 1), Doubles2) - level;
      const Doubles2 m = __builtin_convertvector(__builtin_shufflevector(bottom[b], bottom[b], 0, 1), Doubles2) - level;
      best = larger(best, larger(zero, t) - smaller(zero, m));
    }
    return static_cast<float>(larger(best[0], best[1]));
  }

  // valueAt for any vertex and array.
  float anyValueAt(const Vec3f& p) const noexcept {
    const auto& d = source_.info().dims;  // x, y, z
    const std::array<double, 3> c{p.x, p.y, p.z};
    std::array<std::int64_t, 3> lo{}, cells{};  // the first cell and the cell count (1 or 2) per axis
    for (std::size_t a = 0; a < 3; ++a) {
      const auto f = static_cast<std::int64_t>(std::floor(c[a]));
      const std::int64_t last = d[a] - 2;
      const std::int64_t first = static_cast<double>(f) == c[a] ? f - 1 : f;  // on a plane: both sides
      lo[a] = std::clamp<std::int64_t>(first, 0, last);
      cells[a] = std::clamp<std::int64_t>(f, 0, last) - lo[a] + 1;
    }
    // The points of those cells, each read once (at most 3 x 3 x 3), then each cell's min and max.
    float v[3][3][3];
    for (std::int64_t z = 0; z <= cells[2]; ++z) {
      for (std::int64_t y = 0; y <= cells[1]; ++y) {
        for (std::int64_t x = 0; x <= cells[0]; ++x) v[z][y][x] = source_.at(lo[2] + z, lo[1] + y, lo[0] + x);
      }
    }
    double best = 0;
    for (std::int64_t z = 0; z < cells[2]; ++z) {
      for (std::int64_t y = 0; y < cells[1]; ++y) {
        for (std::int64_t x = 0; x < cells[0]; ++x) {
          float top = v[z][y][x], bottom = top;
          for (int k = 1; k < 8; ++k) {
            const float value = v[z + ((k >> 2) & 1)][y + ((k >> 1) & 1)][x + (k & 1)];
            top = std::max(top, value);
            bottom = std::min(bottom, value);
          }
          // As scikit-image's vmax - vmin, relative to the level and 0 at least on each side.
          best = std::max(best, std::max(0.0, top - level_) - std::min(0.0, bottom - level_));
        }
      }
    }
    return static_cast<float>(best);
  }

  const ArraySource& source_;
  const float* lent_;  // the source's floats when it lends them
  std::array<double, 3> spacing_;
  double level_;
  bool ascent_;
};

// Extracts the iso-surface of `volume`; returns verts (V, 3) float32 in array index order and
// scaled by spacing, faces (F, 3) int32, normals (V, 3) float32 (unit, from high to low values,
// in index space, as scikit-image's) and values (V,) float32.
py::tuple marchingCubes(const py::array& volume, double level, const std::array<double, 3>& spacing,
                        const std::string& method, int threads, bool ascent) {
  const auto m = parseMethod(method);
  if (!m) throw py::value_error("unknown method '" + method + "'");
  ArraySource source(volume);
  ExtractOptions options;
  options.method = *m;
  options.iso = level;
  options.normals = true;
  options.cellVolumes = false;
  ArraySink sink(source, spacing, level, ascent);
  {
    py::gil_scoped_release release;
    // In the voxel frame, as scikit-image extracts: the normals are the field's gradient in index
    // space, and the vertices are scaled by the spacing as they are stored.
    const LatticeFrame frame = LatticeFrame::voxel();
    auto extractor = makeExtractor(options, source.info(), frame);
    PipelineOptions pipeline;
    pipeline.threads = std::max(1, threads);
    runPipeline(source, *extractor, sink, extractionHeader(options, source.info(), frame, *extractor), pipeline);
  }
  if (sink.values.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    throw Error("the mesh has more vertices than int32 faces can index (2^31 - 1)");
  }
  return py::make_tuple(sink.verts.release(3), sink.faces.release(3), sink.normals.release(3), sink.values.release(0));
}

py::dict infoDict(const VolumeInfo& info) {
  py::dict d;
  // In array index order (slices first), as the arrays iter_slices yields stack.
  d["shape"] = py::make_tuple(info.dims[2], info.dims[1], info.dims[0]);
  d["dims"] = py::make_tuple(info.dims[0], info.dims[1], info.dims[2]);
  d["spacing"] = py::make_tuple(info.spacing[0], info.spacing[1], info.spacing[2]);
  d["origin"] = py::make_tuple(info.origin[0], info.origin[1], info.origin[2]);
  d["direction"] = py::cast(std::vector<double>(info.direction.begin(), info.direction.end()));
  d["voxel_type"] = std::string(voxelTypeName(info.type));
  d["frame"] = info.frame;
  d["reader"] = info.reader;
  d["modality"] = info.modality;
  d["value_range"] = info.valueRange ? py::object(py::make_tuple((*info.valueRange)[0], (*info.valueRange)[1]))
                                     : py::object(py::none());
  d["suggested_iso"] = info.suggestedIso ? py::object(py::float_(*info.suggestedIso)) : py::object(py::none());
  d["slice_origins"] = info.sliceOrigins.empty() ? py::object(py::none()) : py::object(py::cast(info.sliceOrigins));
  return d;
}

// Slices of a file, one at a time, as float32 arrays (y, x) with their index and origin.
class SliceReader {
 public:
  explicit SliceReader(const std::vector<std::string>& inputs) : source_(openSource(inputs, SourceOptions{})) {}
  SliceReader& iter() { return *this; }
  py::tuple next() {
    const VolumeInfo& info = source_->info();
    if (k_ >= info.dims[2]) throw py::stop_iteration();
    // The slice's data first, then the array: data that ends early fails before it is allocated.
    bool fetched = false;
    {
      py::gil_scoped_release release;
      fetched = source_->fetchSlice();
    }
    if (!fetched) throw py::stop_iteration();
    py::array_t<float> slice({info.dims[1], info.dims[0]});
    bool ok = false;
    {
      float* out = slice.mutable_data();
      py::gil_scoped_release release;
      ok = source_->readSlice({out, static_cast<std::size_t>(info.sliceVoxels())});
    }
    if (!ok) throw py::stop_iteration();
    std::array<double, 3> origin = info.origin;
    if (!info.sliceOrigins.empty()) {
      origin = info.sliceOrigins[static_cast<std::size_t>(k_)];
    } else {
      for (std::size_t a = 0; a < 3; ++a)
        origin[a] += info.direction[3 * a + 2] * info.spacing[2] * static_cast<double>(k_);
    }
    py::dict geometry;
    geometry["index"] = k_;
    geometry["origin"] = py::make_tuple(origin[0], origin[1], origin[2]);
    geometry["spacing"] = py::make_tuple(info.spacing[0], info.spacing[1], info.spacing[2]);
    geometry["direction"] = py::cast(std::vector<double>(info.direction.begin(), info.direction.end()));
    ++k_;
    return py::make_tuple(slice, geometry);
  }
  py::dict info() const { return infoDict(source_->info()); }

 private:
  std::unique_ptr<SliceSource> source_;
  std::int64_t k_ = 0;
};

// The paper's measures and the mesh statistics of any triangle mesh, as the JSON text of
// `isoslab metrics`.
std::string meshMetrics(const py::array_t<float, py::array::c_style | py::array::forcecast>& verts,
                        const py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>& faces,
                        const std::optional<std::array<double, 4>>& sphere) {
  if (verts.ndim() != 2 || verts.shape(1) != 3) throw py::value_error("verts must be an (N, 3) array");
  if (faces.ndim() != 2 || faces.shape(1) != 3)
    throw py::value_error("faces must be an (M, 3) array of vertex indices");
  IndexedMesh mesh;
  const auto nv = verts.shape(0);
  auto v = verts.unchecked<2>();
  for (py::ssize_t i = 0; i < nv; ++i) mesh.positions.push_back({v(i, 0), v(i, 1), v(i, 2)});
  auto f = faces.unchecked<2>();
  for (py::ssize_t i = 0; i < faces.shape(0); ++i) {
    Triangle t{};
    for (py::ssize_t c = 0; c < 3; ++c) {
      const std::int64_t id = f(i, c);
      if (id < 0 || id >= nv) {
        throw py::value_error("faces[" + std::to_string(i) + "] refers to vertex " + std::to_string(id) +
                              ", not one of the " + std::to_string(nv) + " verts");
      }
      t[static_cast<std::size_t>(c)] = static_cast<VertexId>(id);
    }
    mesh.triangles.push_back(t);
  }
  MeshStatsSink stats;
  ComponentSink components;
  components.summarize(10);
  std::optional<SphereErrorSink> errors;
  std::vector<MeshSink*> sinks{&stats, &components};
  std::optional<Sphere> s;
  if (sphere) {
    if (!((*sphere)[3] > 0)) throw py::value_error("sphere must be (cx, cy, cz, r) with r > 0");
    s = Sphere{{(*sphere)[0], (*sphere)[1], (*sphere)[2]}, (*sphere)[3]};
    errors.emplace(*s);
    sinks.push_back(&*errors);
  }
  nlohmann::ordered_json r;
  {
    py::gil_scoped_release release;
    TeeSink tee(sinks);
    feedMesh(mesh, MeshHeader{}, tee);
    addStatsJson(r, stats.stats());
    r["interior_boundary_edges"] = nullptr;  // unknown: no volume faces
    r["components"] = componentsJson(components.summary());
    if (s) r["sphere"] = sphereJson(sphereReport(*s, stats.stats(), *errors));
  }
  return reportText(r, "the mesh", -1);
}

}  // namespace
}  // namespace isoslab

PYBIND11_MODULE(_isoslab, m) {
  m.doc() = "isoslab's library from NumPy (see the isoslab package)";
  m.attr("__version__") = ISOSLAB_VERSION;
  static py::exception<isoslab::Error> error(m, "Error", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const isoslab::Error& e) {
      error(e.what());
    }
  });
  m.def("marching_cubes", &isoslab::marchingCubes, py::arg("volume"), py::arg("level"), py::arg("spacing"),
        py::arg("method"), py::arg("threads"), py::arg("ascent"));
  m.def("volume_range", &isoslab::volumeRange, py::arg("volume"));
  isoslab::defineExtract(m);
  m.def("read_volume_info", [](const std::vector<std::string>& inputs) {
    auto source = isoslab::openSource(inputs, isoslab::SourceOptions{});
    return isoslab::infoDict(source->info());
  });
  py::class_<isoslab::SliceReader>(m, "SliceReader")
      .def(py::init<const std::vector<std::string>&>())
      .def("__iter__", &isoslab::SliceReader::iter, py::return_value_policy::reference_internal)
      .def("__next__", &isoslab::SliceReader::next)
      .def_property_readonly("info", &isoslab::SliceReader::info);
  m.def("metrics", &isoslab::meshMetrics, py::arg("verts"), py::arg("faces"), py::arg("sphere") = py::none());
}

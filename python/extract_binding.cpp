#include "python/extract_binding.h"

#include <fmt/format.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "core/interrupt.h"
#include "core/mesh_sink.h"
#include "job/extract_job.h"
#include "python/array_source.h"
#include "stream/iso_choice.h"

namespace py = pybind11;

namespace isoslab {
namespace {

// The settings from the package's dict (python/isoslab/__init__.py has checked the types and
// turned every list into a sequence of numbers).
template <typename T>
std::optional<T> get(const py::dict& d, const char* key) {
  if (!d.contains(key) || d[key].is_none()) return std::nullopt;
  return d[key].cast<T>();
}

template <std::size_t N>
std::array<double, N> numbers(const py::dict& d, const char* key) {
  const auto v = d[key].cast<std::vector<double>>();
  if (v.size() != N) throw SettingError(fmt::format("`{}` needs {} numbers, not {}", key, N, v.size()));
  std::array<double, N> a{};
  std::copy(v.begin(), v.end(), a.begin());
  return a;
}

// A choice among names, else a SettingError listing them.
template <typename T>
T choice(const py::dict& d, const char* key, std::initializer_list<std::pair<const char*, T>> names, T fallback) {
  const auto value = get<std::string>(d, key);
  if (!value) return fallback;
  std::string list;
  for (const auto& [name, v] : names) {
    if (*value == name) return v;
    list += (list.empty() ? "" : ", ") + std::string(name);
  }
  throw SettingError(fmt::format("`{}`: unknown value '{}' (use {})", key, *value, list));
}

SourceOptions sourceSettings(const py::dict& d) {
  SourceOptions o;
  if (auto v = get<std::string>(d, "series")) o.dicom.series = *v;
  o.dicom.strict = get<bool>(d, "strict").value_or(false);
  o.dicom.skipBad = get<bool>(d, "skip_bad").value_or(false);
  o.dicom.channel = get<int>(d, "channel").value_or(-1);
  o.niftiXform = choice<NiftiXform>(d, "nifti_xform", {{"sform", NiftiXform::kSform}, {"qform", NiftiXform::kQform}},
                                    NiftiXform::kDefault);
  std::optional<std::array<double, 3>> spacing;
  if (get<py::object>(d, "spacing")) spacing = numbers<3>(d, "spacing");
  if (!get<py::object>(d, "raw_dims")) {
    o.spacing = spacing;
    return o;
  }
  RawOptions r;
  const auto dims = d["raw_dims"].cast<std::vector<std::int64_t>>();
  if (dims.size() != 2 && dims.size() != 3) throw SettingError("`raw_dims` needs X,Y or X,Y,Z");
  for (std::size_t a = 0; a < dims.size(); ++a) r.dims[a] = dims[a];
  const std::string type = get<std::string>(d, "raw_type").value_or("u8");
  const auto parsed = parseVoxelType(type);
  if (!parsed)
    throw SettingError(fmt::format("`raw_type`: unknown voxel type '{}' (use u8 i8 u16 i16 u32 i32 f32 f64)", type));
  r.type = *parsed;
  r.byteOrder = choice<ByteOrder>(d, "raw_endian", {{"little", ByteOrder::kLittle}, {"big", ByteOrder::kBig}},
                                  ByteOrder::kLittle);
  r.headerBytes = get<std::int64_t>(d, "raw_offset").value_or(0);
  if (spacing) r.spacing = *spacing;
  o.raw = r;
  return o;
}

void componentSettings(const py::dict& d, ComponentRules& c) {
  if (auto v = get<std::uint64_t>(d, "keep_largest")) c.keepLargest = *v;
  c.measure = choice<ComponentMeasure>(
      d, "component_measure", {{"triangles", ComponentMeasure::kTriangles}, {"volume", ComponentMeasure::kVolume}},
      ComponentMeasure::kTriangles);
  if (auto v = get<std::uint64_t>(d, "min_triangles")) c.minTriangles = *v;
  if (auto v = get<double>(d, "min_volume")) c.minVolume = *v;
  if (get<py::object>(d, "seed")) {
    const auto s = numbers<3>(d, "seed");
    c.seed = Vec3f{static_cast<float>(s[0]), static_cast<float>(s[1]), static_cast<float>(s[2])};
  }
}

void smoothingSettings(const py::dict& d, SmoothOptions& s) {
  s.iterations = get<int>(d, "smooth").value_or(0);
  s.method = choice<SmoothMethod>(
      d, "smooth_method", {{"sinc", SmoothMethod::kSinc}, {"taubin", SmoothMethod::kTaubin}}, SmoothMethod::kSinc);
  s.passBand = get<double>(d, "pass_band").value_or(s.passBand);
  s.faces = choice<FaceVertices>(d, "smooth_faces", {{"slide", FaceVertices::kSlide}, {"lock", FaceVertices::kLock}},
                                 FaceVertices::kSlide);
  s.recomputeNormals = choice<bool>(d, "smooth_normals", {{"smoothed", true}, {"field", false}}, true);
}

ExtractSettings settingsOf(const py::dict& d) {
  ExtractSettings s;
  s.inputs = d["inputs"].cast<std::vector<std::string>>();
  s.output = d["output"].cast<std::string>();
  s.reportPath = get<std::string>(d, "report").value_or("");
  s.source = sourceSettings(d);
  if (auto iso = get<py::object>(d, "iso")) {
    const std::string text =
        py::isinstance<py::str>(*iso) ? iso->cast<std::string>() : py::repr(py::float_(*iso)).cast<std::string>();
    s.iso = parseIsoRequest(text);
    if (!s.iso) throw SettingError(fmt::format("`iso`: '{}' is not a number, auto, bone or skin", text));
  }
  if (auto isos = get<std::vector<double>>(d, "isos")) s.isos = *isos;
  if (auto labels = get<std::string>(d, "labels")) s.labels = parseLabelRequest(*labels);
  s.labelTable = get<std::string>(d, "label_table").value_or("");
  const std::string method = get<std::string>(d, "method").value_or("mc");
  const auto m = parseMethod(method);
  if (!m) throw SettingError(fmt::format("`method`: unknown method '{}'", method));
  s.method = *m;
  const std::string space = get<std::string>(d, "space").value_or("physical");
  const auto sp = parseOutputSpace(space);
  if (!sp) throw SettingError(fmt::format("`space`: unknown space '{}' (use physical, lps, ras or voxel)", space));
  s.space = *sp;
  s.normals = get<bool>(d, "normals").value_or(false);
  s.closeBoundary = get<bool>(d, "close_boundary").value_or(false);
  s.keepDegenerate = get<bool>(d, "keep_degenerate").value_or(false);
  if (get<py::object>(d, "sphere")) {
    const auto v = numbers<4>(d, "sphere");
    s.sphere = Sphere{{v[0], v[1], v[2]}, v[3]};
  }
  s.threads = get<int>(d, "threads").value_or(0);
  s.maxMemoryMiB = get<int>(d, "max_memory").value_or(s.maxMemoryMiB);
  s.sequentialVoxels = get<std::int64_t>(d, "sequential_voxels").value_or(-1);
  s.dracoLevel = get<int>(d, "draco_level").value_or(s.dracoLevel);
  s.quantBits = get<int>(d, "quant_bits").value_or(0);
  s.chunkTriangles = get<std::int64_t>(d, "chunk_triangles").value_or(s.chunkTriangles);
  s.draco = choice<bool>(d, "draco", {{"on", true}, {"off", false}}, true);
  s.gltfFrame = choice<bool>(d, "gltf_frame", {{"gltf", true}, {"raw", false}}, true);
  if (get<py::object>(d, "roi")) s.roi = numbers<6>(d, "roi");
  s.roiSpace = choice<RoiSpace>(d, "roi_space", {{"voxel", RoiSpace::kVoxel}, {"physical", RoiSpace::kPhysical}},
                                RoiSpace::kVoxel);
  componentSettings(d, s.components);
  smoothingSettings(d, s.smoothing);
  s.passBandGiven = get<double>(d, "pass_band").has_value();
  s.decimate = get<double>(d, "decimate").value_or(1.0);
  s.maxError = get<double>(d, "max_error").value_or(0.0);
  if (auto preview = get<std::string>(d, "preview")) s.preview.path = *preview;
  return s;
}

// Hands the run's progress to the calling thread (which alone may call Python), and its stop.
class ThreadObserver final : public ExtractObserver {
 public:
  void progress(const ExtractProgress& p) override {
    std::lock_guard lock(mutex_);
    latest_ = p;
    stage_ = p.stage;
    fresh_ = true;
    wake_.notify_all();
  }
  bool stopRequested() override { return stop_.load(); }
  std::string spell(const std::string& text) const override { return settingsAsFlags(text); }

  void requestStop() { stop_ = true; }
  void finished() {
    std::lock_guard lock(mutex_);
    done_ = true;
    wake_.notify_all();
  }
  // Waits up to `wait` for news; returns the progress not yet handed on, if any, and whether the
  // run has ended.
  std::pair<std::optional<std::pair<double, std::string>>, bool> next(std::chrono::milliseconds wait) {
    std::unique_lock lock(mutex_);
    wake_.wait_for(lock, wait, [&] { return fresh_ || done_; });
    std::optional<std::pair<double, std::string>> p;
    if (fresh_) p.emplace(latest_.fraction, stage_);
    fresh_ = false;
    return {p, done_};
  }

 private:
  std::mutex mutex_;
  std::condition_variable wake_;
  ExtractProgress latest_;
  std::string stage_;
  bool fresh_ = false;
  bool done_ = false;
  std::atomic<bool> stop_{false};
};

// One run at a time in a process: a run's outputs commit through the process-wide CommitGroup.
std::mutex gRunMutex;

// Runs the job on a thread of its own while this one (holding the GIL only between waits) calls
// `progress` and notices Ctrl-C. Returns the report's JSON text.
std::string runJob(ExtractSettings& settings, const py::dict& settingsDict, const py::object& volume,
                   const py::object& progress) {
#if defined(__GLIBC__)
  // As the program does (cli/main.cpp): buffers of a slab, a chunk or a decimation batch come
  // and go with the stream, and glibc's rising mmap threshold would keep their freed space in the
  // heap (a fifth more peak memory on a 512x512x1024 array, bench/python_extract_memory.py). A
  // fixed threshold maps each large buffer and unmaps it when freed. Process-wide, once.
  static const bool fixedThreshold = ::mallopt(M_MMAP_THRESHOLD, 256 * 1024) == 1;
  (void)fixedThreshold;
#endif
  std::optional<py::array> array;
  std::array<double, 3> spacing{1, 1, 1};
  if (!volume.is_none()) {
    array = volume.cast<py::array>();
    if (get<py::object>(settingsDict, "array_spacing")) spacing = numbers<3>(settingsDict, "array_spacing");
    // Read here, with the GIL; each pass then copies it without Python (`array` keeps the buffer).
    auto prototype = std::make_shared<ArraySource>(*array);
    prototype->setGeometry(spacing, settings.inputs.front());
    settings.openVolume = [prototype]() -> std::unique_ptr<SliceSource> { return prototype->clone(); };
  }
  ThreadObserver observer;
  std::string reportText;
  std::exception_ptr failure;
  std::optional<py::error_already_set> pythonError;
  {
    std::thread worker;
    {
      py::gil_scoped_release release;
      worker = std::thread([&] {
        try {
          std::lock_guard one(gRunMutex);
          const ExtractReport report = runExtract(settings, observer);
          reportText =
              extractReportText(report, settings.output, [](const std::string& t) { return settingsAsFlags(t); });
        } catch (...) {
          failure = std::current_exception();
        }
        observer.finished();
      });
    }
    for (;;) {
      std::pair<std::optional<std::pair<double, std::string>>, bool> news;
      {
        py::gil_scoped_release release;
        news = observer.next(std::chrono::milliseconds(50));
      }
      if (!pythonError && PyErr_CheckSignals() != 0) {
        pythonError.emplace();  // takes the KeyboardInterrupt (or a signal handler's exception)
        observer.requestStop();
      }
      if (!pythonError && news.first && !progress.is_none()) {
        try {
          progress(news.first->first, news.first->second);
        } catch (py::error_already_set& e) {
          pythonError.emplace(std::move(e));
          observer.requestStop();
        }
      }
      if (news.second) break;
    }
    py::gil_scoped_release release;
    worker.join();
  }
  if (pythonError) throw std::move(*pythonError);
  if (failure) {
    try {
      std::rethrow_exception(failure);
    } catch (const Error& e) {
      throw Error(settingsAsFlags(e.what()));  // the program's one line
    }
  }
  return reportText;
}

std::string extract(const py::dict& settingsDict, const py::object& volume, const py::object& progress) {
  ExtractSettings settings = settingsOf(settingsDict);
  return runJob(settings, settingsDict, volume, progress);
}

// One label's surface in scikit-image's index order: vertices (plane, row, column), i.e. the
// output's (z, y, x). Mirroring the axes reverses the winding, which turns isoslab's outward
// order into scikit-image's (marching_cubes with gradient_direction "descent" on the label's mask).
class LabelArraySink final : public MeshSink {
 public:
  void begin(const MeshHeader&) override {}
  void consume(const MeshChunk& c) override {
    if (!started_) {
      first_ = c.firstVertex;
      started_ = true;
    }
    for (const Vec3f& p : c.positions) verts.insert(verts.end(), {p.z, p.y, p.x});
    for (const Triangle& t : c.triangles) {
      for (const VertexId v : t) faces.push_back(static_cast<std::int32_t>(v - first_));
    }
  }
  void finish() override {}

  std::vector<float> verts;
  std::vector<std::int32_t> faces;

 private:
  VertexId first_ = 0;
  bool started_ = false;
};

// A NumPy array of `rows` x `columns` that takes over a vector's contents.
template <typename T>
py::array arrayOf(std::vector<T>&& values, py::ssize_t columns) {
  auto* owned = new std::vector<T>(std::move(values));
  py::capsule free(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  const auto rows = static_cast<py::ssize_t>(owned->size()) / columns;
  return py::array_t<T>({rows, columns}, owned->data(), free);
}

// label_surfaces(): the label job with a LabelArraySink per label instead of files. Returns
// ([(label, name, verts, faces), ...], the report's JSON text).
py::tuple labelSurfaces(const py::dict& settingsDict, const py::object& volume, const py::object& progress) {
  ExtractSettings settings = settingsOf(settingsDict);
  std::deque<std::tuple<std::int32_t, std::string, LabelArraySink>> surfaces;  // addresses stay
  settings.labelSinks = [&surfaces](std::int32_t label, const std::string& name) -> MeshSink* {
    return &std::get<2>(surfaces.emplace_back(label, name, LabelArraySink{}));
  };
  const std::string report = runJob(settings, settingsDict, volume, progress);
  std::sort(surfaces.begin(), surfaces.end(),
            [](const auto& a, const auto& b) { return std::get<0>(a) < std::get<0>(b); });
  py::list out;
  while (!surfaces.empty()) {
    auto& [label, name, sink] = surfaces.front();
    out.append(py::make_tuple(label, name, arrayOf(std::move(sink.verts), 3), arrayOf(std::move(sink.faces), 3)));
    surfaces.pop_front();
  }
  return py::make_tuple(out, report);
}

}  // namespace

void defineExtract(py::module_& m) {
  m.def("extract", &extract, py::arg("settings"), py::arg("volume") = py::none(), py::arg("progress") = py::none());
  m.def("label_surfaces", &labelSurfaces, py::arg("settings"), py::arg("volume"), py::arg("progress") = py::none());
}

}  // namespace isoslab

// Extraction alone, timed like the peers' in-memory runs: the whole volume is read into memory
// first (a benchmark may hold it; the library never does), then the pipeline extracts it R times
// into a sink that only counts, and the median wall time is printed as JSON. The in-memory source
// lends its slices (SliceSource::lendSlice), as VTK reads its in-memory array without a copy.
// Usage: isoslab_extract_only INPUT (--iso V [--method M] | --labels) [--threads N] [--runs R] [--cell-volumes]
//          [--run-voxels V] [--run-triangles T] [--sequential-voxels V] [--trim-threshold BYTES]
// --labels extracts the label complex of every label from the volume padded with background as
// the program pads it: the kernel of `isoslab extract INPUT --labels all` alone, without the
// program's check and count of the labels (io/label_source.h), for a volume of one layer, in its
// physical frame.
// load_seconds is the time to read the file once (opening, decoding, converting to float).
// --run-voxels, --run-triangles and --sequential-voxels set the pipeline's cost model (PipelineOptions), to
// measure it. glibc's malloc is set as the isoslab program sets it (a fixed mmap threshold of
// 256 KiB); --trim-threshold also keeps up to that many freed bytes at the top of each heap, as a
// long-lived process would find its heaps from its earlier runs.
#include <fmt/format.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>
#include <vector>

#include "core/error.h"
#include "extract/extractor.h"
#include "extract/frame.h"
#include "extract/label_extractor.h"
#include "io/open_source.h"
#include "io/pad_source.h"
#include "stream/pipeline.h"

namespace {

class MemorySource final : public isoslab::SliceSource {
 public:
  explicit MemorySource(isoslab::SliceSource& from) : info_(from.info()) {
    const auto n = static_cast<std::size_t>(info_.sliceVoxels());
    values_.resize(n * static_cast<std::size_t>(info_.dims[2]));
    for (std::int64_t k = 0; k < info_.dims[2]; ++k) {
      if (!from.readSlice({values_.data() + static_cast<std::size_t>(k) * n, n})) {
        throw isoslab::Error(fmt::format("{}: short volume", info_.source));
      }
    }
  }
  const isoslab::VolumeInfo& info() const noexcept override { return info_; }
  bool lendsSlices() const noexcept override { return true; }
  const float* lendSlice() override {
    if (next_ >= info_.dims[2]) return nullptr;
    return values_.data() + static_cast<std::size_t>(next_++) * static_cast<std::size_t>(info_.sliceVoxels());
  }
  bool readSlice(std::span<float> slice) override {
    if (next_ >= info_.dims[2]) return false;
    const auto n = slice.size();
    std::memcpy(slice.data(), values_.data() + static_cast<std::size_t>(next_++) * n, n * sizeof(float));
    return true;
  }
  void rewind() { next_ = 0; }

 private:
  isoslab::VolumeInfo info_;
  std::vector<float> values_;
  std::int64_t next_ = 0;
};

class CountingSink final : public isoslab::MeshSink {
 public:
  void begin(const isoslab::MeshHeader&) override { triangles = 0; }
  void consume(const isoslab::MeshChunk& c) override { triangles += c.triangles.size(); }
  void finish() override {}
  std::uint64_t triangles = 0;
};

}  // namespace

int main(int argc, char** argv) {
  std::string input;
  double iso = 0;
  std::string method = "mc";
  int threads = 1;
  int runs = 5;
  bool cellVolumes = false;  // as `isoslab extract` without --report
  bool labels = false;
  isoslab::PipelineOptions p;
  long trim = 0;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    auto value = [&] { return a + 1 < argc ? std::string(argv[++a]) : std::string(); };
    if (arg == "--iso") {
      iso = std::stod(value());
    } else if (arg == "--method") {
      method = value();
    } else if (arg == "--threads") {
      threads = std::stoi(value());
    } else if (arg == "--labels") {
      labels = true;
    } else if (arg == "--cell-volumes") {
      cellVolumes = true;
    } else if (arg == "--run-voxels") {
      p.runVoxels = std::stoll(value());
    } else if (arg == "--run-triangles") {
      p.runTriangles = std::stoll(value());
    } else if (arg == "--sequential-voxels") {
      p.sequentialVoxels = std::stoll(value());
    } else if (arg == "--trim-threshold") {
      trim = std::stol(value());
    } else if (arg == "--runs") {
      runs = std::stoi(value());
    } else {
      input = arg;
    }
  }
#if defined(__GLIBC__)
  ::mallopt(M_MMAP_THRESHOLD, 256 * 1024);
  if (trim > 0) ::mallopt(M_TRIM_THRESHOLD, static_cast<int>(trim));
#endif
  try {
    const auto loadStart = std::chrono::steady_clock::now();
    auto file = isoslab::openSource(input, isoslab::SourceOptions{});
    const isoslab::VolumeInfo unpadded = file->info();
    if (labels) file = std::make_unique<isoslab::PadSource>(std::move(file), 0.0f);
    MemorySource source(*file);
    file.reset();
    const double loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - loadStart).count();
    isoslab::ExtractOptions options;
    options.iso = iso;
    const auto m = isoslab::parseMethod(method);
    if (!m) throw isoslab::Error(fmt::format("unknown method '{}'", method));
    options.method = *m;
    options.cellVolumes = cellVolumes;
    const isoslab::LatticeFrame frame = isoslab::LatticeFrame::physical(unpadded);
    std::vector<double> seconds;
    isoslab::PipelineResult last;
    CountingSink sink;
    for (int r = 0; r < runs; ++r) {
      source.rewind();
      auto extractor =
          labels ? isoslab::makeLabelExtractor(unpadded, frame) : isoslab::makeExtractor(options, source.info(), frame);
      p.threads = threads;
      const auto t = std::chrono::steady_clock::now();
      last = isoslab::runPipeline(source, *extractor, sink, isoslab::MeshHeader{}, p);
      seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count());
    }
    std::sort(seconds.begin(), seconds.end());
    fmt::print(
        "{{\"method\": \"{}\", \"threads\": {}, \"runs\": {}, \"median_seconds\": {:.4f}, "
        "\"best_seconds\": {:.4f}, \"triangles\": {}, \"load_seconds\": {:.4f}, \"workers\": {}, \"run_slabs\": {}, "
        "\"last_run\": {{\"read_wait\": {:.4f}, \"worker_busy\": {:.4f}, \"write_wait\": {:.4f}}}}}\n",
        labels ? std::string("labels") : method, threads, runs, seconds[seconds.size() / 2], seconds.front(),
        sink.triangles, loadSeconds, last.workers, last.runSlabs, last.readSeconds, last.extractSeconds,
        last.writeSeconds);
  } catch (const std::exception& e) {
    fmt::print(stderr, "isoslab_extract_only: {}\n", e.what());
    return 1;
  }
  return 0;
}

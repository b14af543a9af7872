// Google Benchmark micro-benchmarks of the four extraction kernels on in-memory slabs: a dense
// field (a surface through most cells), a sparse one (one small sphere) and a noisy one.
// Reported as cells per second. Run: build/bench/isoslab_kernels
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "extract/extractor.h"
#include "extract/frame.h"

namespace {

using isoslab::Method;

constexpr std::int64_t kN = 128;  // slices of 128 x 128, 8 slabs per iteration

std::vector<float> field(int kind) {
  std::vector<float> v(static_cast<std::size_t>(kN * kN * 10));
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0, 1);
  for (std::int64_t k = 0; k < 10; ++k) {
    for (std::int64_t j = 0; j < kN; ++j) {
      for (std::int64_t i = 0; i < kN; ++i) {
        float& x = v[static_cast<std::size_t>((k * kN + j) * kN + i)];
        if (kind == 0)
          x = std::sin(0.3f * static_cast<float>(i)) + std::cos(0.25f * static_cast<float>(j)) +
              0.1f * static_cast<float>(k);
        if (kind == 1)
          x = 10.0f -
              std::hypot(static_cast<float>(i) - 64.0f, static_cast<float>(j) - 64.0f, static_cast<float>(k) - 5.0f);
        if (kind == 2) x = noise(rng);
      }
    }
  }
  return v;
}

void kernel(benchmark::State& state) {
  const auto method = static_cast<Method>(state.range(0));
  const std::vector<float> values = field(static_cast<int>(state.range(1)));
  isoslab::VolumeInfo info;
  info.dims = {kN, kN, 10};
  isoslab::ExtractOptions options;
  options.method = method;
  options.iso = 0.0;
  options.cellVolumes = false;  // as `isoslab extract` without a report
  std::int64_t cells = 0;
  for (auto _ : state) {
    auto extractor = isoslab::makeExtractor(options, info, isoslab::LatticeFrame::voxel());
    isoslab::MeshChunk chunk;
    for (std::int64_t z = 0; z + 1 < 9; ++z) {
      isoslab::SlabView view;
      view.z = z;
      view.dims = info.dims;
      auto slice = [&](std::int64_t k) { return values.data() + k * kN * kN; };
      view.slices = {z > 0 ? slice(z - 1) : nullptr, slice(z), slice(z + 1), slice(z + 2)};
      chunk.clear();
      extractor->extractSlab(view, chunk);
      benchmark::DoNotOptimize(chunk.triangles.data());
      cells += (kN - 1) * (kN - 1);
    }
  }
  state.counters["cells/s"] = benchmark::Counter(static_cast<double>(cells), benchmark::Counter::kIsRate);
}

}  // namespace

// Arguments: method (0 mc, 1 mt5, 2 mt6, 3 bcc12), field (0 dense, 1 sparse, 2 noisy).
BENCHMARK(kernel)->ArgsProduct({{0, 1, 2, 3}, {0, 1, 2}})->ArgNames({"method", "field"})->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();

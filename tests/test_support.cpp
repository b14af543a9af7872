#include "test_support.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "extract/frame.h"
#include "io/open_source.h"
#include "io/pad_source.h"
#include "stream/pipeline.h"

namespace fs = std::filesystem;

namespace isoslab::testing {

VectorSource::VectorSource(std::array<std::int64_t, 3> dims, std::vector<float> values) : values_(std::move(values)) {
  info_.dims = dims;
  info_.type = VoxelType::kF32;
  info_.reader = "vector";
  info_.source = "vector";
}

VectorSource::VectorSource(std::array<std::int64_t, 3> dims,
                           const std::function<float(std::int64_t, std::int64_t, std::int64_t)>& f)
    : VectorSource(dims, std::vector<float>{}) {
  values_.reserve(static_cast<std::size_t>(dims[0] * dims[1] * dims[2]));
  for (std::int64_t k = 0; k < dims[2]; ++k)
    for (std::int64_t j = 0; j < dims[1]; ++j)
      for (std::int64_t i = 0; i < dims[0]; ++i) values_.push_back(f(i, j, k));
}

bool VectorSource::readSlice(std::span<float> slice) {
  if (next_ >= info_.dims[2]) return false;
  const auto n = static_cast<std::size_t>(info_.sliceValues());
  std::copy_n(values_.begin() + static_cast<std::ptrdiff_t>(n * static_cast<std::size_t>(next_)), n, slice.begin());
  ++next_;
  return true;
}

const float* VectorSource::lendSlice() {
  if (next_ >= info_.dims[2]) return nullptr;
  return values_.data() + static_cast<std::size_t>(info_.sliceValues()) * static_cast<std::size_t>(next_++);
}

Extraction extract(SliceSource& source, Method method, double iso, bool normals) {
  ExtractOptions options;
  options.method = method;
  options.iso = iso;
  options.normals = normals;
  const LatticeFrame frame = LatticeFrame::physical(source.info());
  auto extractor = makeExtractor(options, source.info(), frame);
  MemoryMeshSink memory;
  MeshStatsSink stats;
  TeeSink tee({&memory, &stats});
  MeshHeader header;
  header.normals = normals;
  header.method = std::string(methodName(method));
  header.iso = iso;
  header.cellVolumes = extractor->cellVolumes();
  runPipeline(source, *extractor, tee, header);
  return {memory.mesh(), stats.stats()};
}

Extraction extract(std::unique_ptr<SliceSource> source, const ExtractOptions& options, int threads) {
  const VolumeInfo info = source->info();
  const LatticeFrame frame = LatticeFrame::physical(info);
  auto extractor = makeExtractor(options, info, frame);
  const MeshHeader header = extractionHeader(options, info, frame, *extractor);
  if (options.closeBoundary) source = std::make_unique<PadSource>(std::move(source));
  MemoryMeshSink memory;
  MeshStatsSink stats;
  TeeSink tee({&memory, &stats});
  PipelineOptions pipeline;
  pipeline.threads = threads;
  runPipeline(*source, *extractor, tee, header, pipeline);
  return {memory.mesh(), stats.stats()};
}

Extraction extract(const std::string& input, Method method, double iso, bool normals) {
  auto source = openSource(input, {});
  return extract(*source, method, iso, normals);
}

CliResult runCli(const std::string& args) {
  const std::string dir = tempDir();
  const std::string outPath = dir + "/stdout";
  const std::string errPath = dir + "/stderr";
  const std::string cmd = std::string(ISOSLAB_CLI_PATH) + " " + args + " >" + outPath + " 2>" + errPath + " </dev/null";
  const int status = std::system(cmd.c_str());
  CliResult r;
  r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(outPath);
  r.err = slurp(errPath);
  fs::remove_all(dir);
  return r;
}

namespace {

// Removes this process's temporary folders when the test program ends.
class TempRoot final : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(fs::temp_directory_path() / ("isoslab-test-" + std::to_string(::getpid())), ec);
  }
};

[[maybe_unused]] ::testing::Environment* const kTempRoot = ::testing::AddGlobalTestEnvironment(new TempRoot);

}  // namespace

std::string tempDir() {
  static std::atomic<int> counter{0};
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "isoslab";
  for (char& c : name) {
    if (c == '/') c = '_';
  }
  const fs::path dir = fs::temp_directory_path() / ("isoslab-test-" + std::to_string(::getpid())) /
                       (name + "-" + std::to_string(counter++));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

std::string sharedData(const std::string& name) {
  const fs::path p = fs::path(ISOSLAB_SHARED_DATA) / name;
  std::error_code ec;
  return fs::exists(p, ec) ? p.string() : std::string();
}

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

int fileCount(const std::string& folder) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(folder)) n += e.is_regular_file() ? 1 : 0;
  return n;
}

std::string gltfClientsMissing(const std::string& npm) {
  if (!std::filesystem::exists(npm + "/node_modules/three") ||
      !std::filesystem::exists(npm + "/node_modules/gltf-validator") ||
      std::system("command -v node >/dev/null 2>&1") != 0) {
    return "node and the npm packages in " + npm + " are absent (scripts/test.sh installs them)";
  }
  return "";
}

}  // namespace isoslab::testing

#include "fuzz_support.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "extract/extractor.h"
#include "extract/frame.h"
#include "metrics/mesh_stats.h"
#include "stream/pipeline.h"

namespace fs = std::filesystem;

namespace isoslab::fuzz {
namespace {

// The scratch folder, removed at exit (a crash leaves it in the temporary folder).
class Scratch {
 public:
  Scratch() : root_(fs::temp_directory_path() / ("isoslab-fuzz-" + std::to_string(::getpid()))) {
    std::error_code ec;
    fs::remove_all(root_, ec);
    fs::create_directories(root_);
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(root_, ec);
  }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  const fs::path& root() const { return root_; }

 private:
  fs::path root_;
};

const Scratch& scratch() {
  static const Scratch s;
  return s;
}

}  // namespace

std::string freshDir() {
  const fs::path dir = scratch().root() / "in";
  std::error_code ec;
  fs::remove_all(dir, ec);
  fs::create_directories(dir);
  return dir.string();
}

void writeFile(const std::string& path, Bytes bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!f) fail("cannot write the fuzz input to " + path);
}

std::vector<Bytes> splitFiles(Bytes bytes, std::size_t maxParts) {
  std::vector<Bytes> parts;
  const auto* sep = reinterpret_cast<const std::uint8_t*>(kFileSeparator.data());
  while (parts.size() + 1 < maxParts) {
    const auto it = std::search(bytes.begin(), bytes.end(), sep, sep + kFileSeparator.size());
    if (it == bytes.end()) break;
    const auto n = static_cast<std::size_t>(it - bytes.begin());
    parts.push_back(bytes.first(n));
    bytes = bytes.subspan(n + kFileSeparator.size());
  }
  parts.push_back(bytes);
  return parts;
}

std::uint8_t takeByte(Bytes& bytes) {
  if (bytes.empty()) return 0;
  const std::uint8_t b = bytes.front();
  bytes = bytes.subspan(1);
  return b;
}

VolumeInfo takeVolumeInfo(Bytes& bytes, int span, VoxelType type) {
  VolumeInfo info;
  for (auto& d : info.dims) d = 2 + takeByte(bytes) % span;
  info.type = type;
  info.reader = "fuzz";
  info.source = "fuzz";
  return info;
}

bool smallEnough(const VolumeInfo& info) {
  const auto& d = info.dims;
  if (d[0] <= 0 || d[1] <= 0 || d[2] <= 0) return false;
  if (d[0] > 4096 || d[1] > 4096 || d[2] > 4096) return false;
  return d[0] * d[1] <= (std::int64_t{1} << 18) && d[0] * d[1] * d[2] <= (std::int64_t{1} << 21);
}

void extractAll(SliceSource& source) {
  const VolumeInfo& info = source.info();
  if (!smallEnough(info)) return;
  const LatticeFrame frame = LatticeFrame::forSpace(info, "physical");
  ExtractOptions options;
  options.iso = info.suggestedIso.value_or(0.5);
  auto extractor = makeExtractor(options, info, frame);
  const MeshHeader header = extractionHeader(options, info, frame, *extractor);
  MeshStatsSink stats;
  runPipeline(source, *extractor, stats, header);
  (void)source.warnings();
}

void fail(const std::string& what) {
  std::fprintf(stderr, "fuzz check failed: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

}  // namespace isoslab::fuzz

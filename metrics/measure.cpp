#include "metrics/measure.h"

#include <cmath>

#include "extract/frame.h"

namespace isoslab {

Measurement measureExtraction(SliceSource& source, const ExtractOptions& options, const std::optional<Sphere>& sphere,
                              std::vector<MeshSink*> extraSinks, const SinkWrapper& through) {
  const VolumeInfo& info = source.info();
  const LatticeFrame frame = LatticeFrame::physical(info);
  auto extractor = makeExtractor(options, info, frame);
  MeshStatsSink stats;
  std::optional<SphereErrorSink> errors;
  std::vector<MeshSink*> sinks = std::move(extraSinks);
  sinks.push_back(&stats);
  if (sphere) {
    errors.emplace(*sphere);
    sinks.push_back(&*errors);
  }
  TeeSink tee(sinks);
  const MeshHeader header = extractionHeader(options, info, frame, *extractor);
  Measurement m;
  m.run = runPipeline(source, *extractor, through ? through(tee) : tee, header);
  m.stats = stats.stats();
  if (sphere) m.sphere = sphereReport(*sphere, m.stats, *errors);
  return m;
}

std::optional<Sphere> phantomSphere(const VolumeInfo& info) {
  if (!info.sphere) return std::nullopt;
  const auto& s = info.spacing;
  if (s[0] != s[1] || s[1] != s[2]) return std::nullopt;
  const auto& d = info.direction;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      double dot = 0;
      for (int r = 0; r < 3; ++r)
        dot += d[static_cast<std::size_t>(3 * r + a)] * d[static_cast<std::size_t>(3 * r + b)];
      if (std::abs(dot - (a == b ? 1.0 : 0.0)) > 1e-12) return std::nullopt;
    }
  }
  const LatticeFrame frame = LatticeFrame::physical(info);
  const auto& c = info.sphere->centre;
  return Sphere{frame.map(c[0], c[1], c[2]), info.sphere->radius * s[0]};
}

}  // namespace isoslab

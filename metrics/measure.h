// Runs a source through an extractor into measuring sinks only (no output file): what the
// precision study and `isoslab metrics`-style checks need.
#pragma once

#include <functional>
#include <optional>

#include "extract/extractor.h"
#include "io/slice_source.h"
#include "metrics/mesh_stats.h"
#include "metrics/sphere_metrics.h"
#include "stream/pipeline.h"

namespace isoslab {

struct Measurement {
  MeshStats stats;
  std::optional<SphereReport> sphere;
  PipelineResult run;
};

/// Extracts `source` with `options` in its physical frame, measuring the mesh (and its errors
/// against `sphere`, in output coordinates, when given). Extra sinks (writers) may be appended.
/// `through`, when given, makes a sink that the mesh passes through before it is measured (a
/// smoothing step, say), forwarding to the sink it is given.
using SinkWrapper = std::function<MeshSink&(MeshSink& into)>;
Measurement measureExtraction(SliceSource& source, const ExtractOptions& options, const std::optional<Sphere>& sphere,
                              std::vector<MeshSink*> extraSinks = {}, const SinkWrapper& through = {});

/// The sphere a phantom describes, in the output coordinates of `frame`, if the frame maps spheres
/// to spheres (equal spacing on every axis, orthonormal directions).
std::optional<Sphere> phantomSphere(const VolumeInfo& info);

}  // namespace isoslab

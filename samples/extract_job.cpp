// What `isoslab extract INPUT --iso bone --close-boundary --keep-largest 1 --smooth 10 -o OUT` does,
// as one library call (the README's example): `extract_job INPUT OUT.glb`.
#include <cstdio>

#include "job/extract_job.h"

int main(int argc, char** argv) {  // INPUT: a DICOM folder, NIfTI, NRRD, raw, an image stack, ...
  if (argc != 3) {
    std::fprintf(stderr, "usage: extract_job INPUT OUT.glb\n");
    return 2;
  }
  isoslab::ExtractSettings settings;
  settings.inputs = {argv[1]};
  settings.output = argv[2];                        // .glb, .drc, .ply, .stl or .obj
  settings.iso = isoslab::parseIsoRequest("bone");  // or "300", "auto"
  settings.closeBoundary = true;
  settings.components.keepLargest = 1;
  settings.smoothing.iterations = 10;
  try {
    const isoslab::ExtractReport report = isoslab::runExtract(settings);
    std::printf("%llu triangles\n", static_cast<unsigned long long>(report.stats.triangles));
  } catch (const isoslab::Error& e) {
    std::fprintf(stderr, "extract_job: %s\n", e.what());
    return 1;
  }
}

#include "extract/extractor.h"

#include "extract/lattice_extractor.h"

namespace isoslab {

std::string_view methodName(Method m) noexcept {
  switch (m) {
    case Method::kMarchingCubes:
      return "mc";
    case Method::kTetra5:
      return "mt5";
    case Method::kTetra6:
      return "mt6";
    case Method::kBcc12:
      return "bcc12";
    case Method::kTetra24:
      return "mt24";
    case Method::kMarchingCubes33:
      return "mc33";
  }
  return "?";
}

std::optional<Method> parseMethod(std::string_view name) noexcept {
  for (Method m : kMethods) {
    if (name == methodName(m)) return m;
  }
  return std::nullopt;
}

std::vector<std::string> methodNames() {
  std::vector<std::string> names;
  for (Method m : kMethods) names.emplace_back(methodName(m));
  return names;
}

std::unique_ptr<Extractor> makeExtractor(const ExtractOptions& options, const VolumeInfo& info,
                                         const LatticeFrame& frame) {
  std::unique_ptr<CellScheme> scheme;
  switch (options.method) {
    case Method::kMarchingCubes:
    case Method::kMarchingCubes33:
      break;
    case Method::kTetra5:
      scheme = std::make_unique<CellScheme>(makeTetra5Scheme());
      break;
    case Method::kTetra6:
      scheme = std::make_unique<CellScheme>(makeTetra6Scheme());
      break;
    case Method::kBcc12:
      scheme = std::make_unique<CellScheme>(makeBcc12Scheme());
      break;
    case Method::kTetra24:
      scheme = std::make_unique<CellScheme>(makeTetra24Scheme());
      break;
  }
  return makeLatticeExtractor(options, info, frame, std::move(scheme));
}

MeshHeader extractionHeader(const ExtractOptions& options, const VolumeInfo& info, const LatticeFrame& frame,
                            const Extractor& extractor) {
  MeshHeader header;
  header.normals = options.normals;
  header.method = std::string(methodName(options.method));
  header.iso = options.iso;
  header.space = frame.name();
  header.cellVolumes = extractor.cellVolumes();
  header.volumeBounds = frame.bounds(info.dims);
  header.volumeFaces = frame.faces(info.dims);
  return header;
}

}  // namespace isoslab

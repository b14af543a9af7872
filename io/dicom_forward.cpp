// The DICOM readers as the program and the library see them: each call loads the DICOM module on
// first use and goes through its table (io/dicom_module.h). The module holds the implementations
// under the same names; this file is never linked into it.
#include <filesystem>

#include "core/modules.h"
#include "io/dicom_module.h"
#include "io/dicom_seg.h"

namespace isoslab {
namespace {

const DicomModuleApi& api() {
  using Entry = const DicomModuleApi* (*)();
  static const DicomModuleApi* table =
      reinterpret_cast<Entry>(moduleSymbol(LoadableModule::kDicom, kDicomModuleEntry, "DICOM files"))();
  return *table;
}

}  // namespace

DicomScan scanDicom(const std::vector<std::string>& inputs, const DicomOptions& options) {
  return api().scan(inputs, options);
}

std::unique_ptr<SliceSource> openDicomSeries(const DicomSeries& series, const DicomOptions& options) {
  return api().openSeries(series, options);
}

bool isDicomSegmentation(const std::string& path) {
  // Only a regular file (never a FIFO, whose reading would block) that looks like DICOM loads the
  // module to be asked.
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec) && looksLikeDicom(path) && api().isSegmentation(path);
}

std::unique_ptr<SliceSource> openDicomSegmentation(const std::string& path, int layer,
                                                   std::vector<std::string>* notes) {
  return api().openSegmentation(path, layer, notes);
}

}  // namespace isoslab

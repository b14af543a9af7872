// The DICOM module's entry (libisoslab_dicom.so, core/modules.h): DCMTK's readers behind one table
// of functions. The program and the library hold only io/dicom_forward.cpp, whose scanDicom,
// openDicomSeries, isDicomSegmentation and openDicomSegmentation load the module on the first
// DICOM file and call through this table, so that a run that reads no DICOM pays nothing for
// DCMTK's start-up (its libraries, bound at load, cost about 12 ms before main).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "io/dicom_series.h"

namespace isoslab {

struct DicomModuleApi {
  DicomScan (*scan)(const std::vector<std::string>&, const DicomOptions&);
  std::unique_ptr<SliceSource> (*openSeries)(const DicomSeries&, const DicomOptions&);
  bool (*isSegmentation)(const std::string&);
  std::unique_ptr<SliceSource> (*openSegmentation)(const std::string&, int, std::vector<std::string>*);
};

/// The symbol that the module exports: a function without arguments returning the table.
inline constexpr const char* kDicomModuleEntry = "isoslab_dicom_module";

}  // namespace isoslab

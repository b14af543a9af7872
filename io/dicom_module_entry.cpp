// The DICOM module's one exported symbol (io/dicom_module.h).
#include "io/dicom_module.h"
#include "io/dicom_seg.h"

extern "C" __attribute__((visibility("default"))) const isoslab::DicomModuleApi* isoslab_dicom_module() {
  static const isoslab::DicomModuleApi api{&isoslab::scanDicom, &isoslab::openDicomSeries,
                                           &isoslab::isDicomSegmentation, &isoslab::openDicomSegmentation};
  return &api;
}

// Writes any isoslab input (a phantom, usually) as a DICOM CT series, one file per slice, with
// DCMTK: signed 16-bit pixels, axial orientation, slices `spacing` mm apart. For benchmarks and
// demos of the DICOM path.
//
//   make_dicom_series 'phantom:head?n=512,512,64' OUT_FOLDER
#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "core/error.h"
#include "io/open_source.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: make_dicom_series INPUT OUT_FOLDER\n");
    return 2;
  }
  try {
    auto source = isoslab::openSource(argv[1], {});
    const isoslab::VolumeInfo& info = source->info();
    std::filesystem::create_directories(argv[2]);
    char series[128];
    char study[128];
    dcmGenerateUniqueIdentifier(series, SITE_SERIES_UID_ROOT);
    dcmGenerateUniqueIdentifier(study, SITE_STUDY_UID_ROOT);
    std::vector<float> slice(static_cast<std::size_t>(info.sliceVoxels()));
    std::vector<Sint16> pixels(slice.size());
    for (std::int64_t k = 0; source->readSlice(slice); ++k) {
      for (std::size_t p = 0; p < slice.size(); ++p) {
        pixels[p] = static_cast<Sint16>(std::lround(std::fmin(32767.0, std::fmax(-32768.0, slice[p]))));
      }
      DcmFileFormat file;
      DcmDataset* d = file.getDataset();
      char instance[128];
      d->putAndInsertString(DCM_SOPClassUID, UID_CTImageStorage);
      d->putAndInsertString(DCM_SOPInstanceUID, dcmGenerateUniqueIdentifier(instance, SITE_INSTANCE_UID_ROOT));
      d->putAndInsertString(DCM_StudyInstanceUID, study);
      d->putAndInsertString(DCM_SeriesInstanceUID, series);
      d->putAndInsertString(DCM_Modality, "CT");
      d->putAndInsertString(DCM_SeriesDescription, argv[1]);
      d->putAndInsertString(DCM_InstanceNumber, std::to_string(k + 1).c_str());
      d->putAndInsertUint16(DCM_Rows, static_cast<Uint16>(info.dims[1]));
      d->putAndInsertUint16(DCM_Columns, static_cast<Uint16>(info.dims[0]));
      d->putAndInsertUint16(DCM_SamplesPerPixel, 1);
      d->putAndInsertString(DCM_PhotometricInterpretation, "MONOCHROME2");
      d->putAndInsertUint16(DCM_BitsAllocated, 16);
      d->putAndInsertUint16(DCM_BitsStored, 16);
      d->putAndInsertUint16(DCM_HighBit, 15);
      d->putAndInsertUint16(DCM_PixelRepresentation, 1);
      d->putAndInsertString(DCM_PixelSpacing, fmt::format("{}\\{}", info.spacing[1], info.spacing[0]).c_str());
      d->putAndInsertString(DCM_ImageOrientationPatient, "1\\0\\0\\0\\1\\0");
      d->putAndInsertString(DCM_ImagePositionPatient,
                            fmt::format("0\\0\\{}", static_cast<double>(k) * info.spacing[2]).c_str());
      d->putAndInsertString(DCM_RescaleSlope, "1");
      d->putAndInsertString(DCM_RescaleIntercept, "0");
      d->putAndInsertUint16Array(DCM_PixelData, reinterpret_cast<const Uint16*>(pixels.data()),
                                 static_cast<unsigned long>(pixels.size()));
      const std::string path = fmt::format("{}/slice{:05d}.dcm", argv[2], k);
      if (file.saveFile(path.c_str(), EXS_LittleEndianExplicit).bad()) {
        throw isoslab::Error(fmt::format("{}: cannot write", path));
      }
    }
  } catch (const isoslab::Error& e) {
    std::fprintf(stderr, "make_dicom_series: %s\n", e.what());
    return 1;
  }
  return 0;
}

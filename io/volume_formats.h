// Research volume formats, each read slice by slice through openVolumeFile():
// - NRRD (.nrrd with attached data, .nhdr with a detached data file, a LIST of files or a printf
//   pattern): encodings raw and gzip; every scalar type; endianness; space directions, space
//   origin and spacings. Coordinates in a RAS-based space are converted to LPS.
// - MetaImage (.mha inline, .mhd detached, LIST or pattern): every MET_* scalar type,
//   ElementByteOrderMSB, Offset, TransformMatrix, ElementSpacing, HeaderSize, CompressedData (zlib).
// - NIfTI-1 and NIfTI-2 (.nii, .nii.gz, .hdr/.img pairs): scl_slope and scl_inter; the world
//   frame from the sform when sform_code > 0, else from the qform when qform_code > 0, else from
//   pixdim alone (NiftiXform picks one); NIfTI's RAS world is converted to LPS. A sheared sform is
//   applied as it is (VolumeInfo::direction then has unit columns that are not perpendicular).
//   4-D data: the first volume, with a note.
// All of them report frame "lps" when the file defines a world frame.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "io/slice_source.h"

namespace isoslab {

/// Which NIfTI transform gives the world frame.
enum class NiftiXform {
  kDefault,  // the sform when sform_code > 0, else the qform when qform_code > 0, else pixdim
  kSform,    // the sform; an error when sform_code is 0
  kQform,    // the qform (rigid, as ITK-based tools take it); an error when qform_code is 0
};

/// True if the file name says NRRD, MetaImage or NIfTI (.nrrd .nhdr .mha .mhd .nii .nii.gz .hdr).
bool isVolumeFormat(const std::string& path);

/// Opens a NRRD, MetaImage or NIfTI file by its extension. `channel` picks a component of
/// multi-component data (-1: an error if there is more than one). Notes for the user are appended
/// to `notes`; for NIfTI with both transforms, a "warning: " note when the sform is not orthogonal or
/// disagrees with the qform. `xform` applies to NIfTI only. Throws isoslab::Error naming the file
/// and the problem.
std::unique_ptr<SliceSource> openVolumeFormat(const std::string& path, int channel, std::vector<std::string>* notes,
                                              NiftiXform xform = NiftiXform::kDefault);

}  // namespace isoslab

// DICOM Segmentation objects as label volumes: Segmentation Storage (binary and fractional
// segments, 1.2.840.10008.5.1.4.1.1.66.4) and Label Map Segmentation Storage (one segment number
// per pixel, ...66.7).
//
// Each segment is a label whose value is its SegmentNumber, whose name is its SegmentLabel and
// whose colour is its RecommendedDisplayCIELabValue in sRGB. Frames are placed by their per-frame
// ImagePositionPatient on one slice lattice in patient coordinates (LPS, mm), so the surfaces land
// on the scan the segmentation was drawn on; slices no frame covers are background. A fractional
// segment holds a voxel where its value is at least half MaximumFractionalValue. Segments that
// overlap go to separate layers (a greedy colouring of the overlap graph in segment order), and a
// run reads one layer (`channel`) or every layer in one pass (kEveryLayer), as a 4-D .seg.nrrd is
// read.
//
// Pixel data is read frame by frame from the file (never whole); bits are unpacked here, not by
// DCMTK 3.6.7's dcmseg, whose binary frames are wrong when Rows x Columns is not a multiple of 8
// (DCMTK issue 1132). Native and deflated transfer syntaxes only.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "io/slice_source.h"

namespace isoslab {

/// Whether `path` is a DICOM file whose SOPClassUID is Segmentation Storage or Label Map
/// Segmentation Storage. False for anything that cannot be read as DICOM.
bool isDicomSegmentation(const std::string& path);

/// Opens a DICOM Segmentation object as a label volume (VolumeInfo::labelMap and labels set).
/// `layer` picks the layer of a file whose segments overlap (-1: the file must have one layer;
/// kEveryLayer: all of them, a plane each).
/// Throws isoslab::Error naming the file for anything it cannot place or read: an unsupported
/// transfer syntax, frames off one slice lattice or with other orientations or spacings, a frame
/// naming a segment the file does not describe, pixel data of the wrong length.
std::unique_ptr<SliceSource> openDicomSegmentation(const std::string& path, int layer, std::vector<std::string>* notes);

}  // namespace isoslab

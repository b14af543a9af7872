// The seam between readers and the rest of isoslab: a volume's geometry up front, then its slices
// one at a time, in order, each converted once to float.
//
// A SliceSource never holds the whole volume. Readers are opened by factories (openSource(),
// RawReader::open(), PhantomSource::open()) that throw isoslab::Error with a message naming the
// file and the problem; readSlice() reports truncated or unreadable data the same way.
// A SliceSource is used from one thread at a time.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/volume_info.h"

namespace isoslab {

/// The `channel` that asks a segmentation whose segments lie in several layers (a 4-D .seg.nrrd, a
/// DICOM SEG with overlapping segments) for all of them in one pass: its slices then hold
/// VolumeInfo::layers planes. Any other input takes it as no channel (-1).
constexpr int kEveryLayer = -2;

class SliceSource {
 public:
  virtual ~SliceSource() = default;
  SliceSource() = default;
  SliceSource(const SliceSource&) = delete;
  SliceSource& operator=(const SliceSource&) = delete;

  virtual const VolumeInfo& info() const noexcept = 0;

  /// Reads the next slice into `slice`, which the caller owns and which must hold exactly
  /// info().sliceValues() values, x fastest (one plane per layer, VolumeInfo::layers). Returns false, leaving `slice`
  /// untouched, once all info().dims[2] slices have been read. Throws isoslab::Error if the data is short or
  /// unreadable.
  virtual bool readSlice(std::span<float> slice) = 0;

  /// Reads the next slice's stored data ahead of readSlice(), so that data that ends early fails
  /// before the caller allocates the slice's values: callers that size a buffer per slice call it
  /// first (readSliceInto does). A reader whose data may be shorter than its header says (a
  /// compressed stream) holds only what it found when it throws. Returns false when it knows that
  /// every slice has been read; true does not promise a slice (readSlice() may still return
  /// false). The next readSlice() or skipSlices() uses the fetched slice; fetching twice fetches
  /// it once. The default fetches nothing. Throws isoslab::Error as readSlice() does.
  virtual bool fetchSlice() { return true; }

  /// Moves past the next `n` slices (n >= 0) without handing them out: the next readSlice() gives
  /// the slice after them. Returns how many were skipped, fewer than `n` only when the source ends
  /// first. The default reads them into a scratch slice and drops them. Readers that can find a
  /// slice without reading the ones before it override it and neither read nor decode the skipped
  /// slices: raw, NRRD, MetaImage and NIfTI data that is not compressed seek past them, per-slice
  /// files (raw, NRRD and MetaImage lists, DICOM, image stacks) are not opened, and phantoms
  /// compute nothing. A skipping reader therefore finds no fault in the slices it skips. Throws
  /// isoslab::Error as readSlice() does.
  virtual std::int64_t skipSlices(std::int64_t n);

  /// Whether the source holds its slices in memory as float and can lend them (lendSlice)
  /// instead of copying them, as a volume already in memory can.
  virtual bool lendsSlices() const noexcept { return false; }

  /// The next slice's values, x fastest, valid as long as the source lives; nullptr once all
  /// slices have been handed out. Only for sources that lend slices.
  virtual const float* lendSlice() { return nullptr; }

  /// Problems with the data that are not errors, one line each without a prefix, for the user
  /// (for example bytes left over after the last slice, which suggest wrong dims or type). Call it
  /// after reading every slice: a reader may then read what is left of a compressed stream to
  /// count it. A source whose last slices were never read (see CropSource) gives only the warnings
  /// found so far. Empty for most sources.
  virtual std::vector<std::string> warnings() { return {}; }
};

/// Fetches the next slice of `source`, then sizes `slice` to info().sliceValues() values and reads
/// the slice into it: the buffer is allocated only once the slice's data is there. Returns false,
/// leaving `slice` untouched, at the end of the data. Throws isoslab::Error as readSlice() does.
bool readSliceInto(SliceSource& source, std::vector<float>& slice);

/// Checks a volume's geometry, whatever read it: every spacing finite and positive, the origin and
/// every slice origin finite, the direction's entries finite, no column zero, and the columns
/// neither collinear nor nearly coplanar (a flat or NaN mesh would follow). Throws
/// isoslab::Error "WHAT: FIELD ..." naming the field otherwise. openSource() applies it to every
/// source it opens.
void validateGeometry(const VolumeInfo& info, const std::string& what);

/// Checks that the volume's box, in physical coordinates, is finite in float32 (the meshes'
/// coordinates), and that each lattice step spans at least one float32 step at that box's largest
/// value of the coordinates it moves. Throws isoslab::Error naming the field
/// (VolumeInfo::spacingFields, originField) that puts the box out of range or the step below
/// float32's resolution. `isoslab extract` applies it unless --space is voxel.
void validateFloat32Geometry(const VolumeInfo& info, const std::string& what);

}  // namespace isoslab

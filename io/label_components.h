// The 6-connected components of every label of a label map, found in one pass as its slices
// stream past, and the relabelling that drops some of them in a second pass (per-label
// --keep-largest, --min-volume, --min-triangles). A dropped component's voxels take the label that
// it shares the most voxel faces with (the background, 0, included), so that the label complex
// made from the relabelled volume stays closed and its interfaces shared by construction.
//
// Both passes number the same "parts" the same way: each row of a plane is cut into runs of equal
// values; a run of a label takes the part of the first run of its value that it touches in the
// row before it (same plane), else in the same row of the plane before; a run that touches none
// starts a new part. The first pass also joins the parts that a run touches (union-find) into
// components and counts their voxels and faces; the second replays the numbering alone and
// rewrites the runs of dropped parts. Memory: the runs of two planes, and per part a few numbers
// (first pass) or one value (second). Parts follow the components and their shapes (a part starts
// where a label's run touches no earlier run of it), not the number of slices as such.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "io/slice_source.h"

namespace isoslab {

/// One 6-connected component of one label of one layer.
struct LabelComponent {
  std::int32_t label = 0;  // layeredLabel(layer, value)
  std::int64_t voxels = 0;
  /// Voxel faces on its boundary: with other labels, the background and the volume's faces. The
  /// label complex gives it two triangles per face (before smoothing and decimation).
  std::int64_t faces = 0;
};

/// Which components of each label to keep: every rule given applies, to each label's components
/// apart, first the thresholds, then the N largest of what remains.
struct LabelComponentRules {
  std::optional<std::uint64_t> keepLargest;
  bool largestByVoxels = false;               // else by faces (triangles)
  std::optional<std::uint64_t> minTriangles;  // two per face
  std::optional<double> minVolume;            // voxels times voxelVolume
  double voxelVolume = 1;
};

/// Per component, whether `rules` keep it. Ties of the N largest go to the earlier component.
std::vector<bool> selectLabelComponents(const std::vector<LabelComponent>& components,
                                        const LabelComponentRules& rules);

/// What a relabelling changes for one label.
struct LabelChange {
  std::uint64_t components = 0;  // found
  std::uint64_t dropped = 0;
  std::int64_t voxelsGiven = 0;  // its dropped components' voxels, now other labels'
  std::int64_t voxelsTaken = 0;  // voxels of dropped components that it takes
};

/// The second pass's table: per layer, per part, the value that its voxels take.
struct LabelRelabelling {
  std::vector<std::vector<float>> partValues;
  /// Per layered label (the background of layer L as layeredLabel(L, 0)).
  std::map<std::int32_t, LabelChange> changes;
};

class LabelComponentFinder {
 public:
  /// `info`: the volume's dims and layers; `what` names it in messages. addSlice() throws
  /// isoslab::Error "WHAT: the label map has too many components ..." past 2^32 - 1 parts.
  LabelComponentFinder(const VolumeInfo& info, const std::string& what);
  ~LabelComponentFinder();
  LabelComponentFinder(const LabelComponentFinder&) = delete;
  LabelComponentFinder& operator=(const LabelComponentFinder&) = delete;

  /// The next slice, as a LabelSource hands it out (whole numbers; 0 the background).
  void addSlice(std::span<const float> slice);

  /// After the last slice: every component, layer by layer, each layer's in the order of its first
  /// voxel (x fastest, then y, then z).
  const std::vector<LabelComponent>& components();
  /// The parts numbered (LabelComponentFinder's header comment), over all layers.
  std::uint64_t parts() const noexcept;

  /// The relabelling that drops the components not kept (`keep`, per component). Dropped
  /// components that touch are taken together; each such group goes to the label of the kept
  /// components and the background around it that shares the most faces with it (ties: the lower
  /// value; the volume's faces count as the background's).
  LabelRelabelling relabelling(const std::vector<bool>& keep) const;

 private:
  struct Layer;
  void finish();
  VolumeInfo info_;
  std::vector<std::unique_ptr<Layer>> layers_;
  std::vector<LabelComponent> components_;
  bool finished_ = false;
};

/// A label source relabelled: numbers each plane's parts as the finder did and rewrites the runs
/// whose part takes another value. Its slices must be the finder's, in order (a skip reads the
/// slices it skips). Throws isoslab::Error "WHAT: the input changed between the component rules'
/// two passes" when a plane holds a part that the first pass did not number.
class RelabelSource final : public SliceSource {
 public:
  RelabelSource(std::unique_ptr<SliceSource> inner, std::string what, LabelRelabelling relabelling);
  ~RelabelSource() override;

  const VolumeInfo& info() const noexcept override { return inner_->info(); }
  bool readSlice(std::span<float> slice) override;
  bool fetchSlice() override { return inner_->fetchSlice(); }
  std::int64_t skipSlices(std::int64_t n) override;
  std::vector<std::string> warnings() override { return inner_->warnings(); }

 private:
  struct Planes;
  std::unique_ptr<SliceSource> inner_;
  std::string what_;
  LabelRelabelling relabelling_;
  std::unique_ptr<Planes> planes_;
  std::vector<float> scratch_;
};

}  // namespace isoslab

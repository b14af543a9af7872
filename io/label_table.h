// Names and colours of labels, from a table file: a FreeSurfer colour LUT or a 3D Slicer colour
// table (.ctbl), both "INDEX NAME R G B A"; an ITK-SNAP label description ("IDX R G B A VIS MSH
// "LABEL""); or an "INDEX NAME [...]" text file such as mricron's aal.nii.txt. '#' starts a
// comment; blank lines are skipped. The form is told per line.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace isoslab {

struct LabelEntry {
  std::int32_t value = 0;
  std::string name;
  /// sRGB, 0..255; none when the table gives no colour.
  std::optional<std::array<std::uint8_t, 3>> color;
};

struct LabelTable {
  std::vector<LabelEntry> entries;  // in file order

  const LabelEntry* find(std::int32_t value) const noexcept;
  /// By name: exactly, else ignoring case; nullptr when neither matches.
  const LabelEntry* findName(const std::string& name) const noexcept;
  /// The entry whose name is nearest to `name` (edit distance, ignoring case); nullptr when empty.
  const LabelEntry* nearest(const std::string& name) const noexcept;
};

/// Reads a table. Throws isoslab::Error "PATH:LINE: ..." for a malformed line (a first field that
/// is not a whole number, a missing name, a colour outside 0..255, a value given twice), or when
/// the file cannot be read or holds no entry.
LabelTable readLabelTable(const std::string& path);

/// A colour for a label that has none: distinct hues by the golden angle, fixed per value.
std::array<std::uint8_t, 3> defaultLabelColor(std::int32_t value) noexcept;

}  // namespace isoslab

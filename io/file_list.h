// Lists of input files: a folder's files or a printf pattern's matches, in natural numeric order.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace isoslab {

/// True if `a` sorts before `b` in natural order: runs of digits compare by value ("CThead.2"
/// before "CThead.10"), the rest byte by byte.
bool naturalLess(std::string_view a, std::string_view b) noexcept;

/// The regular files directly inside `folder` whose names do not start with '.', in natural
/// order. Throws isoslab::Error if the folder cannot be read or holds no file.
std::vector<std::string> listFolder(const std::string& folder);

/// True if `pattern` holds one printf integer conversion (%d, %i, %u, optionally with a flag and
/// width such as %03d) and nothing else that printf would interpret.
bool isSlicePattern(std::string_view pattern) noexcept;

/// Expands a printf pattern to the files that exist for consecutive indices, starting at the
/// first of 0 and 1 that exists. Throws isoslab::Error if none does, or if a file for a later
/// index exists after the first missing one (a gap, naming the missing file).
std::vector<std::string> expandPattern(const std::string& pattern);

/// The pattern with `index` substituted.
std::string formatPattern(const std::string& pattern, long index);

}  // namespace isoslab

// The error model of io/ and encode/.
//
// Functions in these folders report failure by throwing isoslab::Error, and only that type. Its
// what() is one complete line that names the file (or the input spec) and the problem, fit to be
// printed as it is after "isoslab: error: ". Extraction kernels (extract/) do not throw.
//
// A message that concerns one of the caller's settings names it in backticks by its snake_case
// name (`iso`, `channel`, `series`, `strict`, `spacing`, `raw_dims`, `raw_type`, `nifti_xform`,
// `draco_level`, `quant_bits`, `chunk_triangles`), never as a command-line flag: a front end spells
// it its own way (the isoslab program writes --channel; see cli/arguments.h, withFlags).
#pragma once

#include <stdexcept>
#include <string>

namespace isoslab {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An Error in the caller's settings rather than in the data: a value out of range, two outputs
/// that name one file, a setting the input needs but was not given. The program exits with its
/// usage status (2) for these, and 1 for every other Error.
class SettingError : public Error {
 public:
  using Error::Error;
};

}  // namespace isoslab

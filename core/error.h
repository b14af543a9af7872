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

}  // namespace isoslab

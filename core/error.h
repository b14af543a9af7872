// The error model of io/ and encode/.
//
// Functions in these folders report failure by throwing isoslab::Error, and only that type. Its
// what() is one complete line that names the file (or the input spec) and the problem, fit to be
// printed as it is after "isoslab: error: ". Extraction kernels (extract/) do not throw.
#pragma once

#include <stdexcept>
#include <string>

namespace isoslab {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace isoslab

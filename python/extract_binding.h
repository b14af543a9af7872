// isoslab._isoslab.extract: the extraction job (job/extract_job.h) in process, for the package's
// isoslab.extract().
#pragma once

#include <pybind11/pybind11.h>

namespace isoslab {

/// Adds extract(settings, volume, progress) to the module.
void defineExtract(pybind11::module_& m);

}  // namespace isoslab

// `isoslab batch LIST --out DIR [-- EXTRACT_OPTIONS]` (issue 20): many inputs, one extraction
// each, spread over local processes (--jobs) and, under mpirun, over the ranks.
#pragma once

#include <string>
#include <vector>

#include "stream/rank_group.h"

namespace isoslab::cli {

struct BatchArgs {
  std::string list;                  // one input per line; blank lines and lines starting with # are skipped
  std::string out;                   // the folder for the meshes, the reports and batch.json
  std::string format = "glb";        // the meshes' extension
  int jobs = 1;                      // extractions at once, per rank
  bool quiet = false;                // no summary table on stdout
  std::vector<std::string> extract;  // options for every `isoslab extract`, after --
};

/// The name of an input's outputs in the batch folder: its file or folder name without the volume
/// extensions (.nii.gz, .nrrd, .mha, ...), or a phantom's spec, with every character other than
/// letters, digits, '.', '-' and '_' replaced by '_'.
std::string batchName(const std::string& input);

/// Runs every input of the list as `isoslab extract INPUT EXTRACT_OPTIONS -q -o DIR/NAME.FORMAT
/// --report DIR/NAME.json`, each in a process of its own, `jobs` at a time; with `ranks`, rank r
/// takes the inputs r, r + N, ... and rank 0 gathers the results. Rank 0 writes DIR/batch.json and
/// prints a table; a failed input is listed with its error and the others go on. Returns 0 when
/// every input succeeded, else 1 (on every rank).
int runBatch(const BatchArgs& args, RankGroup* ranks);

}  // namespace isoslab::cli

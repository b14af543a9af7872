// `isoslab compare`: the paper's experiments (spheres51, paper, cubes), with CSV, a Markdown
// summary and charts.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace isoslab {

struct CompareArgs {
  std::string suite = "spheres51";
  std::string out = "compare-out";
  std::string radii;   // spheres51: a subset "5,10,20" instead of the 51 radii
  std::string centre;  // spheres51: offset of the centre from a grid point (default 0.5,0.5,0.5)
  std::string methods = "mc,mt5,mt6,bcc12,mt24,mc33";
  std::string engine;                 // paper: ../shared/data/engine/engine_256x256x128_uint8.raw.gz
  std::string cthead;                 // paper: ../shared/data/cthead
  int smooth = 0;                     // spheres51: also rows of each method smoothed with N iterations
  std::string smoothMethod = "sinc";  // spheres51: of those rows
  bool charts = true;
  bool quiet = false;
};

int runCompare(const CompareArgs& args);

/// Draws the charts of the spheres51 results `csv` into the folder `out` (compare_charts.cpp);
/// none when the chart script or matplotlib is missing (with a note), or when interrupted.
void drawCharts(const std::string& csv, const std::string& out, bool quiet);

enum class Method : std::uint8_t;
/// The figures suite (compare_figures.cpp).
int runFigures(const CompareArgs& args, const std::vector<Method>& methods);

}  // namespace isoslab

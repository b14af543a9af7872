// `isoslab compare --suite figures`: the paper's image comparison (its appendix Figures A.1 to
// A.5 and Figure 3.6), one PNG per case with every method side by side and labelled.
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>

#include "cli/compare.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "extract/extractor.h"
#include "io/crop_source.h"
#include "io/image_writer.h"
#include "io/open_source.h"
#include "metrics/measure.h"
#include "render/rasterizer.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

struct FigureCase {
  std::string file;   // the PNG's name, without .png
  std::string title;  // what the paper's figure shows
  std::string input;
  SourceOptions options;
  double iso = 0;
  render::View view = *render::presetView("iso");
  std::optional<LatticeBox> crop;
  std::vector<Method> methods;
};

constexpr int kPanel = 360;
constexpr int kStrip = 30;

std::unique_ptr<SliceSource> openCase(const FigureCase& c) {
  auto source = openSource(c.input, c.options);
  if (c.crop) source = std::make_unique<CropSource>(std::move(source), *c.crop);
  return source;
}

// Renders the case for every method into one image, labelled with the method and its triangles.
std::string drawCase(const FigureCase& c, const std::vector<Method>& suite, const std::string& out, bool quiet) {
  const int width = kPanel * static_cast<int>(c.methods.size());
  const int height = kPanel + kStrip;
  std::vector<std::uint8_t> rgb(3 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 255);
  std::vector<ImageLabel> labels;
  std::vector<std::string> cells(suite.size(), "-");
  for (std::size_t m = 0; m < c.methods.size(); ++m) {
    auto source = openCase(c);
    ExtractOptions options;
    options.method = c.methods[m];
    options.iso = c.iso;
    render::RenderSink panel(c.view, kPanel, kPanel, render::Style{});
    const Measurement x = measureExtraction(*source, options, std::nullopt, {&panel});
    const render::Image image = panel.image();
    for (int y = 0; y < kPanel; ++y) {
      const auto from = image.rgb.begin() + 3 * static_cast<std::ptrdiff_t>(y) * kPanel;
      const auto to = rgb.begin() +
                      3 * ((static_cast<std::ptrdiff_t>(y) + kStrip) * width + kPanel * static_cast<std::ptrdiff_t>(m));
      std::copy(from, from + 3 * kPanel, to);
    }
    labels.push_back({kPanel * static_cast<int>(m) + 10, 21,
                      fmt::format("{}: {} triangles", methodName(c.methods[m]), x.stats.triangles), 16});
    const auto column = std::find(suite.begin(), suite.end(), c.methods[m]);
    if (column != suite.end())
      cells[static_cast<std::size_t>(column - suite.begin())] = std::to_string(x.stats.triangles);
  }
  // Thin grey rules between the panels.
  for (std::size_t m = 1; m < c.methods.size(); ++m) {
    for (int y = 0; y < height; ++y) {
      const std::size_t at = 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + m * kPanel);
      rgb[at] = rgb[at + 1] = rgb[at + 2] = 160;
    }
  }
  std::string row = fmt::format("| {} |", c.title);
  for (const std::string& cell : cells) row += " " + cell + " |";
  const std::string path = out + "/" + c.file + ".png";
  writePng(path, width, height, rgb, labels);
  if (!quiet) std::fprintf(stderr, "isoslab: figures: %s -> %s\n", c.title.c_str(), path.c_str());
  return row;
}

std::vector<FigureCase> figureCases(const CompareArgs& args, const std::vector<Method>& methods) {
  std::vector<FigureCase> cases;
  // Figures A.1 to A.3: binary cubes of 2, 6 and 80 inside points per edge (value 100, 0 outside).
  for (int edge : {2, 6, 80}) {
    for (double iso : {100.0, 50.0}) {
      FigureCase c;
      c.file = fmt::format("cube{}_iso{}", edge, iso);
      c.title = fmt::format("cube, edge {}, iso {}", edge, iso);
      // One lattice point of air around the block on every side beyond the cut, so that the camera,
      // fitted to the volume, frames the cube.
      c.input = fmt::format("phantom:box?n={}&lo=2,2,2&hi={},{},{}", edge + 4, edge + 1, edge + 1, edge + 1);
      c.iso = iso;
      c.methods = methods;
      cases.push_back(c);
    }
  }
  // Figure A.4: a binary sphere of radius sqrt(810).
  FigureCase sphere;
  sphere.file = "sphere_r28.46";
  sphere.title = "binary sphere, radius sqrt(810) = 28.46, iso 50";
  sphere.input = "phantom:sphere?n=64&r=28.4604989&field=binary";
  sphere.iso = 50;
  sphere.methods = methods;
  cases.push_back(sphere);
  // Figure A.5: a head, and Figure 3.6: an ear-sized detail of it.
  FigureCase head;
  head.file = "head";
  head.view = *render::presetView("front");
  head.methods = methods;
  if (!args.cthead.empty()) {
    head.title = "CThead skin, iso 600";
    head.input = args.cthead;
    head.options.raw = RawOptions{};
    head.options.raw->dims = {256, 256, 0};
    head.options.raw->type = VoxelType::kU16;
    head.options.raw->byteOrder = ByteOrder::kBig;
    head.options.raw->spacing = {1, 1, 2};
    head.iso = 600;
    // CThead's slices run from the top of the head down (+z is inferior): turn the image upright.
    head.view.roll = 180;
  } else {
    head.title = "head phantom skin (no --cthead), iso -400";
    head.input = "phantom:head?n=256,256,109";
    head.iso = -400;
  }
  cases.push_back(head);
  FigureCase ear = head;
  ear.file = "ear";
  ear.title = head.title + ", the right ear (a detail of the head)";
  ear.view = *render::presetView("right");
  ear.view.roll = head.view.roll;
  ear.crop = args.cthead.empty() ? LatticeBox{{0, 100, 30}, {59, 169, 69}} : LatticeBox{{5, 90, 40}, {54, 159, 84}};
  ear.methods.clear();
  for (Method m : {Method::kTetra5, Method::kTetra6, Method::kBcc12, Method::kTetra24}) {
    if (std::find(methods.begin(), methods.end(), m) != methods.end()) ear.methods.push_back(m);
  }
  cases.push_back(ear);
  return cases;
}

}  // namespace

int runFigures(const CompareArgs& args, const std::vector<Method>& methods) {
  // The images and figures.md appear together, or none of them (an interruption, an error).
  CommitGroup outputs;
  makeOutputFolder(args.out);
  std::string md =
      "# figures: the paper's image comparison\n\nOne PNG per case, every method side by side "
      "(flat shading, a light at the eye; faces seen from behind in blue-grey).\n\n| case |";
  for (Method m : methods) md += fmt::format(" {} |", methodName(m));
  md += "\n|---|";
  for (std::size_t m = 0; m < methods.size(); ++m) md += "---|";
  md += "\n";
  for (const FigureCase& c : figureCases(args, methods)) {
    if (c.methods.empty()) continue;
    std::string row = drawCase(c, methods, args.out, args.quiet);
    md += row + "\n";
  }
  AtomicFile f(args.out + "/figures.md");
  f.write(md.data(), md.size());
  f.commit();
  throwIfInterrupted();
  outputs.commit();
  return 0;
}

}  // namespace isoslab

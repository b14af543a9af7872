#include "job/extract_settings.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <filesystem>
#include <iterator>

#include "core/error.h"
#include "core/volume_info.h"
#include "process/decimation.h"

namespace isoslab {
namespace {

constexpr std::array<std::string_view, 4> kSpaceNames{"physical", "lps", "ras", "voxel"};

/// --threads: more would fail to start (EAGAIN) long before it helped.
constexpr int kMaxThreads = 256;

// Whether two output paths name one file: the same spelling after normalisation, or (when the file
// exists) the same file through links and other spellings.
bool sameFile(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::equivalent(a, b, ec) && !ec) return true;
  // A link to a file that does not exist yet names that file.
  const auto resolve = [&](fs::path p) {
    for (int hops = 0; hops < 40 && fs::is_symlink(fs::symlink_status(p, ec)); ++hops) {
      const fs::path link = fs::read_symlink(p, ec);
      if (ec) break;
      p = link.is_absolute() ? link : p.parent_path() / link;
    }
    return fs::weakly_canonical(fs::absolute(p), ec).lexically_normal();
  };
  return resolve(a) == resolve(b);
}

void require(bool ok, const std::string& message) {
  if (!ok) throw SettingError(message);
}

void checkRanges(const ExtractSettings& s) {
  require(!s.inputs.empty(), "`inputs` names no input");
  require(!s.output.empty() || s.labelSinks, "`output` names no file");
  require(s.threads >= 0 && s.threads <= kMaxThreads,
          fmt::format("`threads` must be 1 to {} (or 0: the default), not {}", kMaxThreads, s.threads));
  require(s.maxMemoryMiB >= 16 && s.maxMemoryMiB <= (1 << 20),
          fmt::format("`max_memory` must be 16 to {} MiB, not {}", 1 << 20, s.maxMemoryMiB));
  require(s.dracoLevel >= 0 && s.dracoLevel <= 10, fmt::format("`draco_level` must be 0 to 10, not {}", s.dracoLevel));
  require(s.quantBits >= 0 && s.quantBits <= 30,
          fmt::format("`quant_bits` must be 1 to 30 (or 0: the default), not {}", s.quantBits));
  require(s.chunkTriangles >= 1, fmt::format("`chunk_triangles` must be at least 1, not {}", s.chunkTriangles));
  if (s.iso && s.iso->kind == IsoRequest::Kind::kValue) {
    require(std::isfinite(s.iso->value), "`iso` must be a finite number");
  }
  if (s.sphere) {
    const Sphere& sp = *s.sphere;
    require(std::isfinite(sp.centre[0]) && std::isfinite(sp.centre[1]) && std::isfinite(sp.centre[2]) &&
                std::isfinite(sp.radius) && sp.radius > 0,
            "`sphere` needs a finite centre and a radius above 0");
  }
  if (s.roi) {
    const auto& v = *s.roi;
    for (double x : v) require(std::isfinite(x), "`roi` needs six finite numbers");
    for (std::size_t a = 0; a < 3; ++a) {
      require(v[a] <= v[a + 3],
              fmt::format("`roi` is reversed: its upper corner is below its lower one on axis {}", a));
    }
  }
  const ComponentRules& c = s.components;
  if (c.keepLargest) require(*c.keepLargest >= 1, "`keep_largest` must be at least 1");
  if (c.minTriangles) require(*c.minTriangles >= 1, "`min_triangles` must be at least 1");
  if (c.minVolume) require(*c.minVolume >= 0 && std::isfinite(*c.minVolume), "`min_volume` must be 0 or more");
  if (c.seed) {
    require(std::isfinite(c.seed->x) && std::isfinite(c.seed->y) && std::isfinite(c.seed->z),
            "`seed` needs three finite numbers");
  }
  const PreviewSettings& p = s.preview;
  if (!p.path.empty()) {
    require(p.width >= 1 && p.height >= 1 && p.width <= 16384 && p.height <= 16384,
            fmt::format("`preview_size` must be 1 to 16384 pixels a side, not {}x{}", p.width, p.height));
  }
}

}  // namespace

std::string_view outputSpaceName(OutputSpace space) noexcept {
  return kSpaceNames[static_cast<std::size_t>(space)];
}

std::optional<OutputSpace> parseOutputSpace(std::string_view name) noexcept {
  for (std::size_t i = 0; i < kSpaceNames.size(); ++i) {
    if (kSpaceNames[i] == name) return static_cast<OutputSpace>(i);
  }
  return std::nullopt;
}

bool isOutputPattern(const std::string& path) noexcept {
  return path.find("{name}") != std::string::npos || path.find("{label}") != std::string::npos ||
         path.find("{iso}") != std::string::npos;
}

LabelRequest parseLabelRequest(const std::string& text) {
  LabelRequest r;
  if (text == "all") return r;
  r.all = false;
  auto whole = [](const std::string& t) -> std::optional<std::int32_t> {
    if (t.empty()) return std::nullopt;
    char* end = nullptr;
    errno = 0;
    const long long v = std::strtoll(t.c_str(), &end, 10);
    if (end != t.c_str() + t.size() || errno != 0 || std::abs(static_cast<double>(v)) > kLargestLabel)
      return std::nullopt;
    return static_cast<std::int32_t>(v);
  };
  // Digits (and a sign) that whole() refused are a number beyond the labels, not a name.
  const auto beyond = [&](const std::string& t) {
    const std::size_t digits = !t.empty() && (t[0] == '-' || t[0] == '+') ? 1 : 0;
    const bool number = digits < t.size() && t.find_first_not_of("0123456789", digits) == std::string::npos;
    require(!number || whole(t).has_value(),
            fmt::format("`labels` '{}' is beyond the labels a map can hold (whole numbers from -{:.0f} to {:.0f})", t,
                        kLargestLabel, kLargestLabel));
  };
  std::size_t at = 0;
  while (at <= text.size()) {
    const std::size_t comma = std::min(text.find(',', at), text.size());
    const std::string item = text.substr(at, comma - at);
    at = comma + 1;
    require(!item.empty(), fmt::format("`labels` '{}' has an empty item (use all, or values, ranges and names "
                                       "separated by commas)",
                                       text));
    if (const auto v = whole(item)) {
      r.ranges.push_back({*v, *v});
      continue;
    }
    beyond(item);
    // A range: the dash after the first character (so that "-4--2" reads as -4 to -2).
    const std::size_t dash = item.find('-', 1);
    if (dash != std::string::npos) {
      beyond(item.substr(0, dash));
      beyond(item.substr(dash + 1));
      const auto lo = whole(item.substr(0, dash));
      const auto hi = whole(item.substr(dash + 1));
      if (lo && hi) {
        require(*lo <= *hi, fmt::format("`labels` range '{}' is reversed", item));
        r.ranges.push_back({*lo, *hi});
        continue;
      }
    }
    r.names.push_back(item);
  }
  return r;
}

std::string settingsAsFlags(const std::string& text) {
  // The settings of SourceOptions, WriterOptions and ExtractSettings that have an option of the
  // same name (`output` is -o).
  static const char* const kSettings[] = {
      "iso",      "series",       "strict",     "skip_bad",    "channel",      "nifti_xform",   "raw_dims",
      "raw_type", "raw_endian",   "raw_offset", "spacing",     "draco_level",  "quant_bits",    "chunk_triangles",
      "roi",      "roi_space",    "smooth",     "pass_band",   "decimate",     "max_error",     "report",
      "preview",  "threads",      "max_memory", "sphere",      "keep_largest", "min_triangles", "min_volume",
      "seed",     "preview_size", "labels",     "label_table", "method",       "normals",       "close_boundary"};
  std::string out;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t open = text.find('`', at);
    const std::size_t close = open == std::string::npos ? open : text.find('`', open + 1);
    if (close == std::string::npos) break;
    const std::string name = text.substr(open + 1, close - open - 1);
    const bool known =
        std::any_of(std::begin(kSettings), std::end(kSettings), [&](const char* s) { return name == s; });
    out += text.substr(at, open - at);
    if (name == "output") {
      out += "-o";
      at = close + 1;
      continue;
    }
    if (known) {
      std::string flag = "--" + name;
      std::replace(flag.begin(), flag.end(), '_', '-');
      out += flag;
      at = close + 1;
    } else {
      out += '`';
      at = open + 1;
    }
  }
  return out + text.substr(std::min(at, text.size()));
}

void checkExtractSettings(const ExtractSettings& s) {
  checkRanges(s);
  if (!s.reportPath.empty() && sameFile(s.reportPath, s.output)) {
    throw SettingError(fmt::format("`report` '{}' names the same file as `output` '{}'", s.reportPath, s.output));
  }
  if (!s.preview.path.empty() &&
      (sameFile(s.preview.path, s.output) || (!s.reportPath.empty() && sameFile(s.preview.path, s.reportPath)))) {
    throw SettingError(fmt::format("`preview` '{}' names the same file as another output", s.preview.path));
  }
  if (s.decimate != 1.0 || s.maxError != 0) {
    DecimateOptions d;
    d.ratio = s.decimate;
    d.maxError = s.maxError;
    if (const std::string e = checkDecimateOptions(d); !e.empty()) throw SettingError(e);
  }
  if (s.smoothing.iterations != 0) {
    if (const std::string e = checkSmoothOptions(s.smoothing); !e.empty()) throw SettingError(e);
  }
  if (s.labels) {
    require(!s.iso && s.isos.empty(), "`iso` and `labels` exclude each other: a run meshes an iso value or labels");
    checkLabelSettings(s);
  }
  if (!s.isos.empty()) {
    require(s.isos.size() >= 2 && !s.iso, "`iso` takes one value, or a list of two or more");
    for (double v : s.isos) require(std::isfinite(v), "`iso` values must be finite numbers");
    std::vector<double> sorted = s.isos;
    std::sort(sorted.begin(), sorted.end());
    require(std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end(), "`iso` lists a value twice");
    checkLabelSettings(s);
  }
}

void checkLabelSettings(const ExtractSettings& s) {
  // Until label surfaces are finished in the stream (the next issue), these are the iso-surface's.
  const char* what = s.isos.empty() ? "label surfaces" : "several iso values in one pass";
  const auto refuse = [what](bool given, const char* name) {
    require(!given, fmt::format("`{}` does not apply to {} yet", name, what));
  };
  // Label maps take the component rules per label (job/label_steps.cpp), several iso values per
  // surface (metrics/component_filter.h), except the seed.
  refuse(s.components.seed.has_value(), "seed");
  if (!s.isos.empty()) {
    refuse(s.smoothing.iterations != 0, "smooth");
    refuse(s.decimate != 1.0, "decimate");
    refuse(s.maxError != 0, "max_error");
  }
  refuse(s.normals, "normals");
  refuse(!s.preview.path.empty(), "preview");
  refuse(s.sphere.has_value(), "sphere");
  if (s.isos.empty()) refuse(s.method != Method::kMarchingCubes, "method");
  if (s.isos.empty()) refuse(s.closeBoundary, "close_boundary");
  if (s.labelSinks) return;  // no file: the caller's sinks take the surfaces
  const std::string ext = std::filesystem::path(s.output).extension().string();
  std::string lower = ext;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  require(isOutputPattern(s.output) || lower == ".ply" || lower == ".glb" || lower == ".3mf",
          fmt::format("`output` '{}' is one file: label surfaces go to a pattern such as 'labels/{{name}}.stl' (a file "
                      "per label), a .glb or .3mf (a mesh per label) or a .ply of the whole label complex",
                      s.output));
  require(
      isOutputPattern(s.output) || lower != ".glb" || s.draco,
      "`draco` off: a .glb of label surfaces is written with Draco chunks only (use a pattern for plain .glb files)");
  if (s.isos.empty()) {
    require(s.output.find("{iso}") == std::string::npos,
            fmt::format("`output` '{}' holds {{iso}}, which label surfaces do not have (use {{name}} or {{label}})",
                        s.output));
  }
}

}  // namespace isoslab

// NRRD: http://teem.sourceforge.net/nrrd/format.html. MetaImage: ITK's MetaIO documentation.
// NIfTI-1 and NIfTI-2: the nifti1.h and nifti2.h header definitions of the NIfTI DFWG.
#include "io/volume_formats.h"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>

#include "core/error.h"
#include "core/limits.h"
#include "core/vec3.h"
#include "core/volume_info.h"
#include "io/file_list.h"
#include "io/volume_file.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && lower(s.substr(s.size() - suffix.size())) == suffix;
}

std::vector<double> numbersIn(const std::string& path, const std::string& key, const std::string& text) {
  std::vector<double> v;
  std::string cleaned = text;
  for (char& c : cleaned) {
    if (c == '(' || c == ')' || c == ',') c = ' ';
  }
  std::istringstream s(cleaned);
  std::string item;
  while (s >> item) {
    char* end = nullptr;
    const double x = std::strtod(item.c_str(), &end);
    if (end != item.c_str() + item.size())
      throw Error(fmt::format("{}: field '{}' has a bad number '{}'", path, key, item));
    v.push_back(x);
  }
  return v;
}

// One whole number of a header field in [lo, hi]; "4.5", "1e30" or NaN are errors (a cast would
// truncate them, or be undefined).
std::int64_t wholeNumber(const std::string& path, const std::string& key, double v, std::int64_t lo, std::int64_t hi) {
  if (!(v == std::floor(v))) throw Error(fmt::format("{}: {} value {} is not a whole number", path, key, v));
  if (!(v >= static_cast<double>(lo) && v <= static_cast<double>(hi))) {
    throw Error(fmt::format("{}: {} value {} is out of range ({} to {})", path, key, v, lo, hi));
  }
  return static_cast<std::int64_t>(v);
}

// A header field that must be one integer: no trailing text, no overflow.
std::int64_t integerField(const std::string& path, const std::string& key, const std::string& text) {
  const std::string t = trim(text);
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(t.c_str(), &end, 10);
  if (t.empty() || end != t.c_str() + t.size()) {
    throw Error(fmt::format("{}: field '{}' is not an integer: '{}'", path, key, t.substr(0, 60)));
  }
  if (errno == ERANGE) throw Error(fmt::format("{}: field '{}' is out of range: '{}'", path, key, t.substr(0, 60)));
  return static_cast<std::int64_t>(v);
}

// A spacing field's three values: finite and positive.
void checkSpacing(const std::string& path, const std::string& key, const std::array<double, 3>& s) {
  for (std::size_t a = 0; a < 3; ++a) {
    if (!std::isfinite(s[a])) throw Error(fmt::format("{}: {} {} along axis {} is not finite", path, key, s[a], a));
    if (!(s[a] > 0)) throw Error(fmt::format("{}: {} {} along axis {} is not positive", path, key, s[a], a));
  }
}

// Resolves a data file named in a header relative to the header's folder.
std::string besides(const std::string& header, const std::string& name) {
  const fs::path p(name);
  if (p.is_absolute()) return name;
  return (fs::path(header).parent_path() / p).string();
}

// "pattern min max step": the files of a printf pattern.
std::vector<std::string> patternFiles(const std::string& header, const std::string& spec) {
  std::istringstream s(spec);
  std::string pattern;
  long first = 0, last = 0, step = 1;
  s >> pattern >> first >> last >> step;
  const bool parsed = !s.fail();
  std::string subdim, extra;  // NRRD allows a sub-dimension after the step, nothing more
  if (parsed) s >> subdim >> extra;
  if (!parsed || !isSlicePattern(pattern) || step == 0 || !extra.empty()) {
    throw Error(fmt::format("{}: bad data file pattern '{}'", header, spec));
  }
  // Count the names before making any (the bounds are 64-bit, the difference may not be).
  const long double names = (static_cast<long double>(last) - static_cast<long double>(first)) / step;
  if (names >= static_cast<long double>(limits::kMaxDataFiles)) {
    throw Error(fmt::format("{}: the data file pattern '{}' names more than the limit of {} files", header, spec,
                            limits::kMaxDataFiles));
  }
  std::vector<std::string> files;
  if (names < 0) return files;
  const long count = static_cast<long>(names) + 1;
  for (long n = 0; n < count; ++n) {
    long value = 0;
    if (__builtin_mul_overflow(n, step, &value) || __builtin_add_overflow(first, value, &value)) {
      throw Error(fmt::format("{}: the data file pattern '{}' counts beyond 64-bit numbers", header, spec));
    }
    files.push_back(besides(header, formatPattern(pattern, value)));
  }
  return files;
}

// Axes (direction times spacing) and origin from the header fields `axesField` and `originField`.
// Non-finite or zero axes are named here, by their field; validateGeometry() checks the rest.
void setGeometry(VolumeInfo& info, const std::array<Vec3d, 3>& axes, const Vec3d& origin, const std::string& axesField,
                 const std::string& originField) {
  for (const double o : origin) {
    if (!std::isfinite(o)) {
      throw Error(
          fmt::format("{}: {} {},{},{} is not finite", info.source, originField, origin[0], origin[1], origin[2]));
    }
  }
  for (int a = 0; a < 3; ++a) {
    const Vec3d& v = axes[static_cast<std::size_t>(a)];
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
      throw Error(
          fmt::format("{}: {} for axis {} is ({},{},{}): not finite", info.source, axesField, a, v[0], v[1], v[2]));
    }
    const double len = std::hypot(v[0], v[1], v[2]);
    if (!(len > 0)) throw Error(fmt::format("{}: {} for axis {} is a zero vector", info.source, axesField, a));
    info.spacing[static_cast<std::size_t>(a)] = len;
    for (int r = 0; r < 3; ++r)
      info.direction[static_cast<std::size_t>(3 * r + a)] = v[static_cast<std::size_t>(r)] / len;
  }
  info.origin = origin;
  info.spacingFields = {axesField, axesField, axesField};
  info.originField = originField;
}

void pickComponent(VolumeFileLayout& layout, double components, int channel, const std::string& path) {
  if (!(components >= 1 && components <= static_cast<double>(limits::kMaxComponents)) ||
      components != std::floor(components)) {
    throw Error(fmt::format("{}: {} components per voxel; a volume needs 1 to {} (the limit)", path, components,
                            limits::kMaxComponents));
  }
  layout.components = static_cast<int>(components);
  const int count = layout.components;
  if (count == 1 && channel >= 1) {
    throw Error(fmt::format("`channel`: {} has one value per voxel (channel 0 only)", path));
  }
  if (count > 1) {
    if (channel < 0)
      throw Error(fmt::format("{}: {} components per voxel; choose one with `channel` 0..{}", path, count, count - 1));
    if (channel >= count) throw Error(fmt::format("`channel`: {} has {} components per voxel", path, count));
    layout.component = channel;
  }
}

// Where the data starts in `file` when it ends the file ("byte skip: -1", "HeaderSize = -1").
std::int64_t dataFromEnd(const std::string& path, const std::string& file, const std::array<std::int64_t, 3>& dims,
                         const VolumeFileLayout& layout) {
  validateDims(dims, path);  // the voxel count then fits in 60 bits
  std::int64_t bytes = 0;
  const bool overflow = __builtin_mul_overflow(
      dims[0] * dims[1] * dims[2], static_cast<std::int64_t>(voxelSize(layout.type)) * layout.components, &bytes);
  std::error_code ec;
  const auto size = static_cast<std::int64_t>(fs::file_size(file, ec));
  if (ec) throw Error(fmt::format("{}: cannot open: {}", file, ec.message()));
  if (overflow || size < bytes) {
    throw Error(fmt::format("{}: holds {} bytes, fewer than dims {}x{}x{} of {} need", file, size, dims[0], dims[1],
                            dims[2], voxelTypeName(layout.type)));
  }
  return size - bytes;
}

// The data files a header names in `dataFile` (NRRD "data file", MetaImage "ElementDataFile"):
// the header's own file from `localOffset` when `local`, the listed names for "LIST", the files of
// a "pattern min max step", or one file beside the header.
void setDataFiles(VolumeFileLayout& layout, const std::string& path, const std::string& dataFile, bool local,
                  std::int64_t localOffset, const std::vector<std::string>& listed) {
  if (local) {
    layout.files = {path};
    layout.fileOffset = localOffset;
  } else if (dataFile.rfind("LIST", 0) == 0) {
    layout.files = listed;
    layout.perSlice = true;
  } else if (dataFile.find(' ') != std::string::npos) {
    layout.files = patternFiles(path, dataFile);
    layout.perSlice = true;
  } else {
    layout.files = {besides(path, dataFile)};
  }
}

// A header's count of bytes before the data (NRRD "byte skip", MetaImage "HeaderSize", named
// `field` in messages): the count, or nothing for -1, where the data ends the file and
// layout.fileOffset is set to where it starts. -1 needs one raw data file (`oneFile`, and no
// compression); "<path>: <minusOne> needs one raw data file" otherwise.
std::optional<std::int64_t> headerSkip(VolumeFileLayout& layout, const std::string& path, const std::string& key,
                                       const std::string& value, const std::string& field, const std::string& minusOne,
                                       bool oneFile, const std::array<std::int64_t, 3>& dims) {
  const std::int64_t skip = integerField(path, key, value);
  if (skip < -1) throw Error(fmt::format("{}: {} {} is negative (only -1 has a meaning)", path, field, skip));
  if (skip != -1) return skip;
  if (layout.compression != Compression::kNone || !oneFile) {
    throw Error(fmt::format("{}: {} needs one raw data file", path, minusOne));
  }
  layout.fileOffset = dataFromEnd(path, layout.files[0], dims, layout);
  return std::nullopt;
}

// --- NRRD ---------------------------------------------------------------------------------------

std::optional<VoxelType> nrrdType(const std::string& t) {
  static const std::map<std::string, VoxelType> kTypes = {{"signed char", VoxelType::kI8},
                                                          {"int8", VoxelType::kI8},
                                                          {"int8_t", VoxelType::kI8},
                                                          {"uchar", VoxelType::kU8},
                                                          {"unsigned char", VoxelType::kU8},
                                                          {"uint8", VoxelType::kU8},
                                                          {"uint8_t", VoxelType::kU8},
                                                          {"short", VoxelType::kI16},
                                                          {"short int", VoxelType::kI16},
                                                          {"signed short", VoxelType::kI16},
                                                          {"signed short int", VoxelType::kI16},
                                                          {"int16", VoxelType::kI16},
                                                          {"int16_t", VoxelType::kI16},
                                                          {"ushort", VoxelType::kU16},
                                                          {"unsigned short", VoxelType::kU16},
                                                          {"unsigned short int", VoxelType::kU16},
                                                          {"uint16", VoxelType::kU16},
                                                          {"uint16_t", VoxelType::kU16},
                                                          {"int", VoxelType::kI32},
                                                          {"signed int", VoxelType::kI32},
                                                          {"int32", VoxelType::kI32},
                                                          {"int32_t", VoxelType::kI32},
                                                          {"uint", VoxelType::kU32},
                                                          {"unsigned int", VoxelType::kU32},
                                                          {"uint32", VoxelType::kU32},
                                                          {"uint32_t", VoxelType::kU32},
                                                          {"float", VoxelType::kF32},
                                                          {"double", VoxelType::kF64}};
  const auto it = kTypes.find(lower(t));
  if (it == kTypes.end()) return std::nullopt;
  return it->second;
}

// std::getline within the header limit: a header (LIST names aside) longer than
// limits::kMaxHeaderBytes, or more listed names than limits::kMaxDataFiles, is an error rather
// than an allocation. `used` counts the header's bytes so far.
bool headerLine(std::istream& in, std::string& line, const std::string& path, bool listing, std::int64_t& used,
                std::size_t listed) {
  if (listing && listed >= static_cast<std::size_t>(limits::kMaxDataFiles)) {
    throw Error(
        fmt::format("{}: the data file list names more than the limit of {} files", path, limits::kMaxDataFiles));
  }
  line.clear();
  std::streambuf* bytes = in.rdbuf();
  for (;;) {
    const int c = bytes->sbumpc();
    if (c == std::char_traits<char>::eof()) {
      in.setstate(line.empty() ? std::ios::eofbit | std::ios::failbit : std::ios::eofbit);
      return !line.empty();
    }
    if (!listing && ++used > limits::kMaxHeaderBytes) {
      throw Error(fmt::format("{}: the header exceeds the limit of {} bytes", path, limits::kMaxHeaderBytes));
    }
    if (c == '\n') return true;
    if (static_cast<std::int64_t>(line.size()) >= limits::kMaxHeaderBytes) {
      throw Error(fmt::format("{}: a header line exceeds the limit of {} bytes", path, limits::kMaxHeaderBytes));
    }
    line.push_back(static_cast<char>(c));
  }
}

std::unique_ptr<SliceSource> openNrrd(const std::string& path, int channel, std::vector<std::string>* notes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  std::string line;
  std::int64_t used = 0;
  if (!headerLine(in, line, path, false, used, 0) || line.rfind("NRRD000", 0) != 0)
    throw Error(fmt::format("{}: not a NRRD file (no NRRD000x magic)", path));
  std::map<std::string, std::string> fields;
  std::map<std::string, std::string> keyValues;  // key:=value pairs (Slicer's segment metadata)
  std::vector<std::string> listed;
  bool list = false;
  while (headerLine(in, line, path, list, used, listed.size())) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (list) {
      if (!trim(line).empty()) listed.push_back(besides(path, trim(line)));
      continue;
    }
    if (line.empty()) break;  // attached data follows
    if (line[0] == '#') continue;
    if (const auto pair = line.find(":="); pair != std::string::npos) {
      keyValues[line.substr(0, pair)] = line.substr(pair + 2);
      continue;
    }
    const auto colon = line.find(": ");
    if (colon == std::string::npos) continue;  // junk
    const std::string key = lower(trim(line.substr(0, colon)));
    const std::string value = trim(line.substr(colon + 2));
    fields[key] = value;
    if ((key == "data file" || key == "datafile") && value.rfind("LIST", 0) == 0) list = true;
  }
  std::error_code sizeError;
  const std::int64_t headerEnd =
      in.eof() ? static_cast<std::int64_t>(fs::file_size(path, sizeError)) : static_cast<std::int64_t>(in.tellg());
  if (sizeError) throw Error(fmt::format("{}: cannot read its size: {}", path, sizeError.message()));
  auto need = [&](const std::string& key) -> const std::string& {
    const auto it = fields.find(key);
    if (it == fields.end()) throw Error(fmt::format("{}: NRRD field '{}' is missing", path, key));
    return it->second;
  };
  VolumeInfo info;
  info.reader = "nrrd";
  info.source = path;
  VolumeFileLayout layout;
  layout.describedBy = "NRRD header";
  const auto type = nrrdType(need("type"));
  if (!type) throw Error(fmt::format("{}: NRRD type '{}' is not supported", path, need("type")));
  layout.type = *type;
  info.type = *type;
  const std::int64_t dimension = integerField(path, "dimension", need("dimension"));
  const auto sizes = numbersIn(path, "sizes", need("sizes"));
  if (static_cast<std::int64_t>(sizes.size()) != dimension || dimension < 3 || dimension > 4) {
    throw Error(
        fmt::format("{}: NRRD dimension {} with sizes '{}' is not a 3-D volume", path, dimension, need("sizes")));
  }
  // A 4-D NRRD is either components first (kinds "vector", "RGB-color", a segmentation's "list" of
  // layers, ...) or a series last. Its one axis that is not spatial is told by `kinds` (the axes that
  // are not "domain" or "space"), else by the "none" of `space directions`, else by the first kind.
  std::size_t first = 0;
  double components = 1;
  bool seriesLast = false;
  if (dimension == 4) {
    std::vector<std::size_t> byKinds, byDirections;
    if (fields.count("kinds")) {
      std::istringstream k(lower(fields["kinds"]));
      std::size_t axis = 0;
      for (std::string kind; k >> kind; ++axis) {
        // "???" and "none" say nothing of the axis.
        if (kind != "domain" && kind != "space" && kind != "???" && kind != "none") byKinds.push_back(axis);
      }
    }
    if (fields.count("space directions")) {
      std::istringstream d(fields["space directions"]);
      std::size_t axis = 0;
      for (std::string token; d >> token; ++axis) {
        if (token == "none") {
          byDirections.push_back(axis);
          continue;
        }
        while (token.find(')') == std::string::npos && d >> token) {
        }
      }
    }
    const auto named = [](const std::vector<std::size_t>& axes) {
      return axes.size() == 1 && (axes[0] == 0 || axes[0] == 3);
    };
    if ((!byKinds.empty() && !named(byKinds)) || (!byDirections.empty() && !named(byDirections)) ||
        (!byKinds.empty() && !byDirections.empty() && byKinds != byDirections)) {
      throw Error(
          fmt::format("{}: NRRD kinds '{}' and space directions '{}' do not name one non-spatial axis, first or last",
                      path, fields.count("kinds") ? fields["kinds"] : "",
                      fields.count("space directions") ? fields["space directions"] : ""));
    }
    // Neither names it: a series last where the kinds begin with space, else components first.
    const std::string kinds = lower(fields.count("kinds") ? fields["kinds"] : "");
    seriesLast = !byKinds.empty()        ? byKinds[0] == 3
                 : !byDirections.empty() ? byDirections[0] == 3
                                         : kinds.rfind("domain", 0) == 0 || kinds.rfind("space", 0) == 0;
    if (!seriesLast) {
      components = sizes[0];
      first = 1;
    } else if (notes != nullptr) {
      notes->push_back(fmt::format("{}: 4-D data; reading the first of {} volumes", path, sizes[3]));
    }
  }
  for (std::size_t a = 0; a < 3; ++a)
    info.dims[a] =
        wholeNumber(path, fmt::format("NRRD sizes: axis {}", first + a), sizes[first + a], 1, limits::kMaxAxisPoints);
  // 3D Slicer's segmentation: SegmentN_Name, _Color (three numbers 0..1), _LabelValue, _Layer;
  // a 4-D file holds one layer per component. Every SegmentN_ key counts, whatever the numbering's
  // gaps; a segment that the file describes is read whole, or the file is refused.
  // The N of a key "SegmentN_REST" (and REST), if it is one.
  const auto segmentKey = [](const std::string& key) -> std::optional<std::pair<int, std::string>> {
    constexpr std::string_view prefix = "Segment";
    if (key.rfind(prefix, 0) != 0) return std::nullopt;
    const std::size_t underscore = key.find('_', prefix.size());
    // Digits only, and no leading zero (Segment03_ would be looked up as Segment3_).
    if (underscore == std::string::npos || underscore == prefix.size() ||
        !std::all_of(key.begin() + static_cast<std::ptrdiff_t>(prefix.size()),
                     key.begin() + static_cast<std::ptrdiff_t>(underscore),
                     [](char c) { return c >= '0' && c <= '9'; }) ||
        (key[prefix.size()] == '0' && underscore > prefix.size() + 1)) {
      return std::nullopt;
    }
    int n = 0;
    const auto [end, error] = std::from_chars(key.data() + prefix.size(), key.data() + underscore, n);
    if (error != std::errc() || end != key.data() + underscore) return std::nullopt;
    return std::pair{n, key.substr(underscore + 1)};
  };
  std::set<int> segments;
  for (const auto& [key, value] : keyValues) {
    if (const auto k = segmentKey(key); k && k->second == "LabelValue") segments.insert(k->first);
  }
  for (const auto& [key, value] : keyValues) {
    const auto k = segmentKey(key);
    if (!segments.empty() && k && segments.count(k->first) == 0) {
      throw Error(fmt::format("{}: {} describes a segment with no Segment{}_LabelValue", path, key, k->first));
    }
  }
  const double layersRead = seriesLast ? 1 : components;
  for (const int n : segments) {
    VolumeInfo::Label label;
    const std::string key = fmt::format("Segment{}_", n);
    const auto value = numbersIn(path, key + "LabelValue", keyValues[key + "LabelValue"]);
    if (value.size() != 1) {
      throw Error(
          fmt::format("{}: {}LabelValue '{}' is not one whole number", path, key, keyValues[key + "LabelValue"]));
    }
    label.value = static_cast<std::int32_t>(wholeNumber(path, key + "LabelValue", value[0], 1, kLargestLabel));
    label.name = keyValues.count(key + "Name") != 0 ? keyValues[key + "Name"] : std::to_string(label.value);
    if (keyValues.count(key + "Color") != 0) {
      const auto c = numbersIn(path, key + "Color", keyValues[key + "Color"]);
      if (c.size() != 3 || !std::all_of(c.begin(), c.end(), [](double x) { return x >= 0 && x <= 1; })) {
        throw Error(
            fmt::format("{}: {}Color '{}' is not three numbers from 0 to 1", path, key, keyValues[key + "Color"]));
      }
      label.color = std::array<std::uint8_t, 3>{static_cast<std::uint8_t>(std::lround(c[0] * 255)),
                                                static_cast<std::uint8_t>(std::lround(c[1] * 255)),
                                                static_cast<std::uint8_t>(std::lround(c[2] * 255))};
    }
    if (keyValues.count(key + "Layer") != 0) {
      const auto layer = numbersIn(path, key + "Layer", keyValues[key + "Layer"]);
      if (layer.size() != 1) {
        throw Error(fmt::format("{}: {}Layer '{}' is not one whole number", path, key, keyValues[key + "Layer"]));
      }
      label.layer = static_cast<int>(wholeNumber(path, key + "Layer", layer[0], 0, 65535));
    }
    if (!seriesLast && label.layer >= layersRead) {
      throw Error(fmt::format("{}: {}Layer {} is beyond the file's {} layer{}", path, key, label.layer, layersRead,
                              layersRead == 1 ? "" : "s"));
    }
    for (const VolumeInfo::Label& other : info.labels) {
      if (other.value == label.value && other.layer == label.layer) {
        throw Error(fmt::format("{}: {} and {} both have LabelValue {} in layer {}", path, other.name, label.name,
                                label.value, label.layer));
      }
    }
    info.labels.push_back(std::move(label));
  }
  // Slicer writes a segmentation's layers on the first axis; read from a series on the last, every
  // layer but the first would be dropped.
  if (seriesLast && !info.labels.empty()) {
    throw Error(
        fmt::format("{}: its segmentation layers lie on the last axis; isoslab reads them from "
                    "the first, as 3D Slicer writes them",
                    path));
  }
  bool everyLayer = false;
  if (!info.labels.empty()) {
    info.labelMap = true;
    everyLayer = components > 1 && channel == kEveryLayer;
    if (everyLayer && components > kMaxLayers) {
      throw Error(fmt::format("{}: {} segmentation layers; one pass reads at most {}: choose one with `channel`", path,
                              components, kMaxLayers));
    }
    if (components > 1 && channel < 0 && !everyLayer) {
      throw Error(
          fmt::format("{}: {} segmentation layers (segments of different layers may overlap); a run meshes "
                      "one: choose it with `channel` 0..{}",
                      path, components, components - 1));
    }
    // The segments of the layer read (of every layer, each plane of a slice holding one).
    const int layer = components > 1 ? channel : 0;
    if (!everyLayer) std::erase_if(info.labels, [&](const VolumeInfo::Label& l) { return l.layer != layer; });
  }
  if (everyLayer) {
    layout.components = static_cast<int>(components);
    layout.component = -1;
    info.layers = layout.components;
  } else {
    pickComponent(layout, components, channel, path);
  }
  const std::string encoding = lower(fields.count("encoding") ? fields["encoding"] : "raw");
  if (encoding == "gzip" || encoding == "gz") {
    layout.compression = Compression::kDeflate;
  } else if (encoding != "raw") {
    throw Error(fmt::format("{}: NRRD encoding '{}' is not supported (raw or gzip)", path, encoding));
  }
  const std::string endian = lower(fields.count("endian") ? fields["endian"] : "little");
  if (endian != "little" && endian != "big") {
    throw Error(fmt::format("{}: NRRD endian '{}' is neither little nor big", path, endian.substr(0, 60)));
  }
  layout.byteOrder = endian == "big" ? ByteOrder::kBig : ByteOrder::kLittle;
  // Geometry.
  const std::string space = lower(fields.count("space") ? fields["space"] : "");
  if (fields.count("space directions")) {
    std::string dirs = fields["space directions"];
    std::vector<std::array<double, 3>> axes;
    std::istringstream s(dirs);
    std::string token;
    while (s >> token) {
      if (token == "none") continue;
      std::string vec = token;
      while (vec.find(')') == std::string::npos && s >> token) vec += token;
      const auto v = numbersIn(path, "space directions", vec);
      if (v.size() != 3) throw Error(fmt::format("{}: NRRD space directions must be 3-vectors", path));
      axes.push_back({v[0], v[1], v[2]});
    }
    if (axes.size() < 3) throw Error(fmt::format("{}: NRRD space directions name fewer than 3 axes", path));
    Vec3d origin{0, 0, 0};
    if (fields.count("space origin")) {
      const auto o = numbersIn(path, "space origin", fields["space origin"]);
      if (o.size() != 3) throw Error(fmt::format("{}: NRRD space origin must be a 3-vector", path));
      origin = {o[0], o[1], o[2]};
    }
    const bool ras = space == "right-anterior-superior" || space == "ras" || space == "scanner-xyz";
    if (ras) {
      for (auto& v : axes) v = {-v[0], -v[1], v[2]};
      origin = {-origin[0], -origin[1], origin[2]};
    }
    setGeometry(info, {axes[0], axes[1], axes[2]}, origin, "NRRD space directions", "NRRD space origin");
    if (space.find("left") != std::string::npos || space == "lps" || ras) info.frame = "lps";
  } else if (fields.count("spacings")) {
    const auto sp = numbersIn(path, "spacings", fields["spacings"]);
    if (sp.size() != static_cast<std::size_t>(dimension))
      throw Error(fmt::format("{}: NRRD spacings need one value per axis", path));
    for (std::size_t a = 0; a < 3; ++a) info.spacing[a] = sp[first + a];
    checkSpacing(path, "NRRD spacings", info.spacing);
  }
  // Data.
  std::string dataFile;
  if (fields.count("data file")) dataFile = fields["data file"];
  if (fields.count("datafile")) dataFile = fields["datafile"];
  setDataFiles(layout, path, dataFile, dataFile.empty(), headerEnd, listed);
  if (fields.count("line skip") && integerField(path, "line skip", fields["line skip"]) != 0) {
    throw Error(fmt::format("{}: NRRD 'line skip' is not supported (only 0)", path));
  }
  if (fields.count("byte skip")) {
    const auto skip = headerSkip(layout, path, "byte skip", fields["byte skip"], "NRRD byte skip", "'byte skip: -1'",
                                 layout.files.size() == 1, info.dims);
    if (skip) layout.skipBytes = *skip;
  }
  return openVolumeFile(info, layout);
}

// --- MetaImage ----------------------------------------------------------------------------------

std::optional<VoxelType> metType(const std::string& t) {
  // MetaIO's 32-bit "long" aliases, beside the canonical names.
  if (t == "MET_LONG") return VoxelType::kI32;
  if (t == "MET_ULONG") return VoxelType::kU32;
  return voxelTypeFromMetaImage(t);
}

// Whether a header line is text: UTF-8 without control characters other than tab. A line that is
// not is quoted in no message (its bytes could drive a terminal); the message says it is binary.
bool isTextLine(std::string_view line) {
  for (std::size_t at = 0; at < line.size();) {
    const auto u = static_cast<unsigned char>(line[at]);
    if (u < 0x80) {
      if ((u < 0x20 && u != '\t') || u == 0x7f) return false;
      ++at;
      continue;
    }
    // A multi-byte sequence: its length from the lead byte, then continuation bytes, shortest form.
    const std::size_t length = u >= 0xc2 && u <= 0xdf ? 2 : u >= 0xe0 && u <= 0xef ? 3 : u >= 0xf0 && u <= 0xf4 ? 4 : 0;
    if (length == 0 || at + length > line.size()) return false;
    std::uint32_t code = u & (0x7fu >> length);
    for (std::size_t k = 1; k < length; ++k) {
      const auto c = static_cast<unsigned char>(line[at + k]);
      if ((c & 0xc0) != 0x80) return false;
      code = (code << 6) | (c & 0x3fu);
    }
    const std::uint32_t least = length == 2 ? 0x80 : length == 3 ? 0x800 : 0x10000;
    if (code < least || code > 0x10ffff || (code >= 0xd800 && code <= 0xdfff) || code < 0xa0) return false;
    at += length;
  }
  return true;
}

bool isTrue(const std::string& v) {
  return lower(v) == "true" || v == "1";
}

std::unique_ptr<SliceSource> openMetaImage(const std::string& path, int channel) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  std::map<std::string, std::string> fields;
  std::vector<std::string> listed;
  std::string line;
  std::int64_t dataStart = -1;
  bool list = false;
  std::int64_t used = 0;
  int lineNumber = 0;
  while (headerLine(in, line, path, list, used, listed.size())) {
    ++lineNumber;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (list) {
      if (!trim(line).empty()) listed.push_back(besides(path, trim(line)));
      continue;
    }
    const auto eq = line.find('=');
    if (eq == std::string::npos) {
      if (trim(line).empty()) continue;
      if (!isTextLine(line)) {
        throw Error(fmt::format("{}: header line {} holds binary bytes, not a MetaImage 'Key = Value' field", path,
                                lineNumber));
      }
      // At most 60 bytes, not cutting a UTF-8 character in two.
      std::size_t cut = std::min<std::size_t>(line.size(), 60);
      while (cut < line.size() && cut > 0 && (static_cast<unsigned char>(line[cut]) & 0xc0) == 0x80) --cut;
      throw Error(fmt::format("{}: not a MetaImage header line: '{}'", path, line.substr(0, cut)));
    }
    const std::string key = trim(line.substr(0, eq));
    const std::string value = trim(line.substr(eq + 1));
    fields[key] = value;
    if (key == "ElementDataFile") {
      if (value == "LOCAL") {
        dataStart = static_cast<std::int64_t>(in.tellg());
        break;
      }
      if (value.rfind("LIST", 0) == 0) {
        list = true;
        continue;
      }
      break;
    }
  }
  auto need = [&](const std::string& key) -> const std::string& {
    const auto it = fields.find(key);
    if (it == fields.end()) throw Error(fmt::format("{}: MetaImage field '{}' is missing", path, key));
    return it->second;
  };
  VolumeInfo info;
  info.reader = "metaimage";
  info.source = path;
  info.frame = "lps";
  VolumeFileLayout layout;
  layout.describedBy = "MetaImage header";
  const auto type = metType(need("ElementType"));
  if (!type) throw Error(fmt::format("{}: MetaImage ElementType '{}' is not supported", path, need("ElementType")));
  layout.type = *type;
  info.type = *type;
  const auto dims = numbersIn(path, "DimSize", need("DimSize"));
  if (dims.size() < 3 || (dims.size() == 4 && dims[3] != 1) || dims.size() > 4) {
    throw Error(fmt::format("{}: DimSize '{}' is not a 3-D volume", path, need("DimSize")));
  }
  for (std::size_t a = 0; a < 3; ++a)
    info.dims[a] = wholeNumber(path, fmt::format("DimSize: axis {}", a), dims[a], 1, limits::kMaxAxisPoints);
  double components = 1;
  if (fields.count("ElementNumberOfChannels")) {
    const auto n = numbersIn(path, "ElementNumberOfChannels", fields["ElementNumberOfChannels"]);
    components = n.size() == 1 ? n[0] : 0;
  }
  pickComponent(layout, components, channel, path);
  const std::string msb = fields.count("ElementByteOrderMSB")      ? fields["ElementByteOrderMSB"]
                          : fields.count("BinaryDataByteOrderMSB") ? fields["BinaryDataByteOrderMSB"]
                                                                   : "False";
  layout.byteOrder = isTrue(msb) ? ByteOrder::kBig : ByteOrder::kLittle;
  if (fields.count("CompressedData") && isTrue(fields["CompressedData"])) layout.compression = Compression::kDeflate;
  std::array<Vec3d, 3> axes{Vec3d{1, 0, 0}, Vec3d{0, 1, 0}, Vec3d{0, 0, 1}};
  std::string axesKey = "TransformMatrix";
  for (const char* key : {"TransformMatrix", "Rotation", "Orientation"}) {
    if (!fields.count(key)) continue;
    axesKey = key;
    const auto m = numbersIn(path, key, fields[key]);
    if (m.size() != 9) throw Error(fmt::format("{}: {} needs 9 values", path, key));
    for (std::size_t a = 0; a < 3; ++a) axes[a] = {m[3 * a], m[3 * a + 1], m[3 * a + 2]};
    break;
  }
  std::array<double, 3> spacing{1, 1, 1};
  for (const char* key : {"ElementSpacing", "ElementSize"}) {
    if (!fields.count(key)) continue;
    const auto s = numbersIn(path, key, fields[key]);
    if (s.size() < 3) throw Error(fmt::format("{}: {} needs 3 values", path, key));
    spacing = {s[0], s[1], s[2]};
    checkSpacing(path, key, spacing);
    break;
  }
  for (std::size_t a = 0; a < 3; ++a) {
    for (double& c : axes[a]) c *= spacing[a];
  }
  Vec3d origin{0, 0, 0};
  std::string originKey = "Offset";
  for (const char* key : {"Offset", "Origin", "Position"}) {
    if (!fields.count(key)) continue;
    const auto o = numbersIn(path, key, fields[key]);
    if (o.size() < 3) throw Error(fmt::format("{}: {} needs 3 values", path, key));
    origin = {o[0], o[1], o[2]};
    originKey = key;
    break;
  }
  setGeometry(info, axes, origin, axesKey, originKey);
  const std::string& dataFile = need("ElementDataFile");
  setDataFiles(layout, path, dataFile, dataFile == "LOCAL", dataStart, listed);
  if (fields.count("HeaderSize")) {
    const auto skip = headerSkip(layout, path, "HeaderSize", fields["HeaderSize"], "HeaderSize", "HeaderSize -1",
                                 !layout.perSlice, info.dims);
    if (const std::int64_t h = skip.value_or(0); h > 0) {
      // Within the data file (the first, for per-slice files), so that offsets cannot overflow.
      std::error_code ec;
      const auto size = static_cast<std::int64_t>(fs::file_size(layout.files[0], ec));
      if (ec) throw Error(fmt::format("{}: cannot open: {}", layout.files[0], ec.message()));
      if (h > size - layout.fileOffset) {
        throw Error(
            fmt::format("{}: HeaderSize {} is beyond the end of {} ({} bytes)", path, h, layout.files[0], size));
      }
      layout.fileOffset += h;
    }
  }
  return openVolumeFile(info, layout);
}

// --- NIfTI --------------------------------------------------------------------------------------

template <typename T>
T get(const std::vector<unsigned char>& h, std::size_t at, bool swap) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, h.data() + at, sizeof(T));
  if (swap) std::reverse(b, b + sizeof(T));
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

// What differs between a NIfTI file's sform and qform (axes and origin in RAS, mm per voxel
// index), or empty when they agree: the sform's shear (the largest departure of an angle between
// its axes from 90 degrees) and the largest distance between the two maps over the volume's eight
// corner voxels. The text ends by saying which one isoslab uses and how.
std::string xformDisagreement(const std::array<Vec3d, 3>& sformAxes, const Vec3d& sformOrigin,
                              const std::array<Vec3d, 3>& qformAxes, const Vec3d& qformOrigin,
                              const std::array<std::int64_t, 3>& dims, bool useSform) {
  // Float32 srow values are good to about 1e-7: a cosine of 1e-4 (0.006 degrees) is a real shear,
  // and 0.01 mm a real disagreement, well below any voxel.
  constexpr double kCosineTolerance = 1e-4;
  constexpr double kDistanceTolerance = 0.01;
  double shear = 0;  // degrees
  bool sheared = false;
  for (std::size_t a = 0; a < 3; ++a) {
    for (std::size_t b = a + 1; b < 3; ++b) {
      const double lengths = std::sqrt(dot(sformAxes[a], sformAxes[a]) * dot(sformAxes[b], sformAxes[b]));
      if (!(lengths > 0)) continue;
      const double cosine = std::clamp(dot(sformAxes[a], sformAxes[b]) / lengths, -1.0, 1.0);
      sheared = sheared || std::abs(cosine) > kCosineTolerance;
      shear = std::max(shear, std::abs(90.0 - std::acos(cosine) * 180.0 / std::numbers::pi));
    }
  }
  double apart = 0;  // mm
  for (int corner = 0; corner < 8; ++corner) {
    Vec3d s = sformOrigin;
    Vec3d q = qformOrigin;
    for (std::size_t a = 0; a < 3; ++a) {
      const double index = (corner >> a) & 1 ? static_cast<double>(std::max<std::int64_t>(dims[a] - 1, 0)) : 0.0;
      for (std::size_t r = 0; r < 3; ++r) {
        s[r] += index * sformAxes[a][r];
        q[r] += index * qformAxes[a][r];
      }
    }
    const Vec3d d{s[0] - q[0], s[1] - q[1], s[2] - q[2]};
    apart = std::max(apart, norm(d));
  }
  const bool disagree = apart > kDistanceTolerance;
  if (!sheared && !disagree) return {};
  std::string what;
  if (sheared) {
    what = fmt::format(
        "the sform is not orthogonal: its axes are sheared by up to {:.3g} degrees (a tilted-gantry series gives "
        "this)",
        shear);
    if (disagree) what += fmt::format(", and the rigid qform places the volume's corners up to {:.3g} mm away", apart);
  } else {
    what =
        fmt::format("the sform and the qform disagree: they place the volume's corners up to {:.3g} mm apart", apart);
  }
  if (!useSform) return what + "; isoslab uses the qform, as `nifti_xform` asks";
  if (sheared) {
    return what + "; isoslab applies the sform as it is, shear included (`nifti_xform` qform takes the rigid qform)";
  }
  return what + "; isoslab uses the sform (`nifti_xform` qform takes the qform)";
}

std::unique_ptr<SliceSource> openNifti(const std::string& path, std::vector<std::string>* notes, NiftiXform xform) {
  // The header, read through the same (possibly gzip) stream as the data.
  std::vector<unsigned char> h(540, 0);
  std::int64_t got = 0;
  {
    gzFile f = gzopen(path.c_str(), "rb");
    if (f == nullptr) throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
    const int n = gzread(f, h.data(), 540);
    int zerr = Z_OK;
    const char* reason = gzerror(f, &zerr);
    const bool compressed = gzdirect(f) == 0;
    std::string what = reason != nullptr ? reason : "";
    if (what.rfind(path + ": ", 0) == 0) what = what.substr(path.size() + 2);  // zlib names the file too
    gzclose(f);
    got = n < 0 ? 0 : n;
    // A short header from a broken gzip stream is a corrupt file, not a short one.
    if (got < 540 && compressed && zerr != Z_OK && zerr != Z_STREAM_END) {
      if (got < 348 || zerr != Z_BUF_ERROR) {
        throw Error(fmt::format("{}: corrupt gzip data: {}", path, what.empty() ? "inflate failed" : what));
      }
    }
  }
  if (got < 348) throw Error(fmt::format("{}: too short for a NIfTI header ({} bytes)", path, got));
  const auto size32 = get<std::int32_t>(h, 0, false);
  bool swap = false;
  int version = 0;
  if (size32 == 348 || size32 == 540) {
    version = size32 == 348 ? 1 : 2;
  } else {
    const auto swapped = get<std::int32_t>(h, 0, true);
    if (swapped == 348 || swapped == 540) {
      swap = true;
      version = swapped == 348 ? 1 : 2;
    }
  }
  if (version == 0) {
    throw Error(
        fmt::format("{}: not a NIfTI file: sizeof_hdr is {}, not 348 (NIfTI-1) or 540 (NIfTI-2)", path, size32));
  }
  if (version == 2 && got < 540) throw Error(fmt::format("{}: too short for a NIfTI-2 header ({} bytes)", path, got));
  std::array<std::int64_t, 8> dim{};
  std::array<double, 8> pixdim{};
  int datatype = 0;
  int bitpix = 0;
  int intent = 0;  // intent_code
  double voxOffset = 0, slope = 0, inter = 0;
  int qformCode = 0, sformCode = 0;
  double qb = 0, qc = 0, qd = 0;
  Vec3d qoffset{};
  std::array<std::array<double, 4>, 3> srow{};
  if (version == 1) {
    for (std::size_t i = 0; i < 8; ++i) {
      dim[i] = get<std::int16_t>(h, 40 + 2 * i, swap);
      pixdim[i] = get<float>(h, 76 + 4 * i, swap);
    }
    intent = get<std::int16_t>(h, 68, swap);
    datatype = get<std::int16_t>(h, 70, swap);
    bitpix = get<std::int16_t>(h, 72, swap);
    voxOffset = get<float>(h, 108, swap);
    slope = get<float>(h, 112, swap);
    inter = get<float>(h, 116, swap);
    qformCode = get<std::int16_t>(h, 252, swap);
    sformCode = get<std::int16_t>(h, 254, swap);
    qb = get<float>(h, 256, swap);
    qc = get<float>(h, 260, swap);
    qd = get<float>(h, 264, swap);
    qoffset = {get<float>(h, 268, swap), get<float>(h, 272, swap), get<float>(h, 276, swap)};
    for (std::size_t r = 0; r < 3; ++r) {
      for (std::size_t c = 0; c < 4; ++c) srow[r][c] = get<float>(h, 280 + 16 * r + 4 * c, swap);
    }
  } else {
    datatype = get<std::int16_t>(h, 12, swap);
    bitpix = get<std::int16_t>(h, 14, swap);
    for (std::size_t i = 0; i < 8; ++i) {
      dim[i] = get<std::int64_t>(h, 16 + 8 * i, swap);
      pixdim[i] = get<double>(h, 104 + 8 * i, swap);
    }
    voxOffset = static_cast<double>(get<std::int64_t>(h, 168, swap));
    intent = get<std::int32_t>(h, 508, swap);
    slope = get<double>(h, 176, swap);
    inter = get<double>(h, 184, swap);
    qformCode = get<std::int32_t>(h, 344, swap);
    sformCode = get<std::int32_t>(h, 348, swap);
    qb = get<double>(h, 352, swap);
    qc = get<double>(h, 360, swap);
    qd = get<double>(h, 368, swap);
    qoffset = {get<double>(h, 376, swap), get<double>(h, 384, swap), get<double>(h, 392, swap)};
    for (std::size_t r = 0; r < 3; ++r) {
      for (std::size_t c = 0; c < 4; ++c) srow[r][c] = get<double>(h, 400 + 32 * r + 8 * c, swap);
    }
  }
  VolumeInfo info;
  info.reader = version == 1 ? "nifti1" : "nifti2";
  info.source = path;
  info.labelMap = intent == 1002;  // NIFTI_INTENT_LABEL
  VolumeFileLayout layout;
  layout.describedBy = "NIfTI header";
  const auto type = voxelTypeFromNifti(datatype);
  if (!type) throw Error(fmt::format("{}: NIfTI datatype {} is not supported", path, datatype));
  layout.type = *type;
  info.type = layout.type;
  if (bitpix != static_cast<int>(8 * voxelSize(*type))) {
    throw Error(fmt::format("{}: NIfTI bitpix {} does not match datatype {} ({} bits)", path, bitpix, datatype,
                            8 * voxelSize(*type)));
  }
  if (dim[0] < 3 || dim[0] > 7) throw Error(fmt::format("{}: NIfTI dim[0] is {}: not a 3-D volume", path, dim[0]));
  for (std::size_t a = 0; a < 3; ++a) {
    if (dim[a + 1] < 2 || dim[a + 1] > limits::kMaxAxisPoints) {
      throw Error(fmt::format("{}: NIfTI dim[{}] is {}: an axis needs 2 to {} points", path, a + 1, dim[a + 1],
                              limits::kMaxAxisPoints));
    }
    info.dims[a] = dim[a + 1];
  }
  double volumes = 1;  // a note only: a double cannot overflow here
  for (std::size_t a = 4; a <= static_cast<std::size_t>(dim[0]); ++a)
    volumes *= static_cast<double>(std::max<std::int64_t>(1, dim[a]));
  if (volumes > 1 && notes != nullptr)
    notes->push_back(fmt::format("{}: {}-D data; reading the first of {} volumes", path, dim[0], volumes));
  // scl_slope 0 means unscaled; any other slope, and its intercept, must be a number.
  if (slope != 0 && (!std::isfinite(slope) || !std::isfinite(inter))) {
    throw Error(fmt::format("{}: NIfTI scl_slope {} and scl_inter {} are not finite", path, slope, inter));
  }
  if (slope != 0 && !(slope == 1 && inter == 0)) {
    layout.slope = slope;
    layout.intercept = inter;
  }
  // World frame: sform, then qform, then pixdim (or the one --nifti-xform names); NIfTI's RAS
  // world becomes LPS. Both transforms are affine maps of the voxel index (i, j, k), in RAS.
  if (xform == NiftiXform::kSform && sformCode <= 0) {
    throw Error(fmt::format("{}: `nifti_xform` sform: the file has no sform (sform_code is {})", path, sformCode));
  }
  if (xform == NiftiXform::kQform && qformCode <= 0) {
    throw Error(fmt::format("{}: `nifti_xform` qform: the file has no qform (qform_code is {})", path, qformCode));
  }
  std::array<Vec3d, 3> sformAxes{};
  const Vec3d sformOrigin{srow[0][3], srow[1][3], srow[2][3]};
  for (std::size_t a = 0; a < 3; ++a) sformAxes[a] = {srow[0][a], srow[1][a], srow[2][a]};
  std::array<Vec3d, 3> qformAxes{};
  const bool useSform = sformCode > 0 && xform != NiftiXform::kQform;
  const bool useQform = !useSform && qformCode > 0;
  if (useQform && (!std::isfinite(qb) || !std::isfinite(qc) || !std::isfinite(qd))) {
    throw Error(fmt::format("{}: NIfTI qform quaternion ({},{},{}) is not finite", path, qb, qc, qd));
  }
  if (useSform) {
    for (std::size_t r = 0; r < 3; ++r) {
      for (std::size_t c = 0; c < 4; ++c) {
        if (!std::isfinite(srow[r][c])) {
          throw Error(fmt::format("{}: NIfTI sform srow_{}[{}] is {}: not finite", path, "xyz"[r], c, srow[r][c]));
        }
      }
    }
  }
  if (!useSform) {  // the qform and the fallback take their spacing from pixdim
    checkSpacing(path, "NIfTI pixdim", {pixdim[1], pixdim[2], pixdim[3]});
  }
  {
    const double qfac = pixdim[0] < 0 ? -1.0 : 1.0;
    const double qa = std::sqrt(std::max(0.0, 1.0 - (qb * qb + qc * qc + qd * qd)));
    const double R[3][3] = {{qa * qa + qb * qb - qc * qc - qd * qd, 2 * (qb * qc - qa * qd), 2 * (qb * qd + qa * qc)},
                            {2 * (qb * qc + qa * qd), qa * qa + qc * qc - qb * qb - qd * qd, 2 * (qc * qd - qa * qb)},
                            {2 * (qb * qd - qa * qc), 2 * (qc * qd + qa * qb), qa * qa + qd * qd - qc * qc - qb * qb}};
    const double scale[3] = {pixdim[1], pixdim[2], pixdim[3] * qfac};
    for (std::size_t a = 0; a < 3; ++a) qformAxes[a] = {R[0][a] * scale[a], R[1][a] * scale[a], R[2][a] * scale[a]};
  }
  if (sformCode > 0 && qformCode > 0 && notes != nullptr) {
    const std::string problem = xformDisagreement(sformAxes, sformOrigin, qformAxes, qoffset, info.dims, useSform);
    if (!problem.empty()) notes->push_back(fmt::format("warning: {}: {}", path, problem));
  }
  std::array<Vec3d, 3> axes{};
  Vec3d origin{};
  std::string axesField = "NIfTI pixdim";
  std::string originField = "NIfTI origin";
  if (useSform) {
    axesField = "NIfTI sform (srow)";
    originField = "NIfTI sform offset";
    axes = sformAxes;
    origin = sformOrigin;
    info.frame = "lps";
  } else if (useQform) {
    axesField = "NIfTI pixdim (with the qform)";
    originField = "NIfTI qoffset";
    axes = qformAxes;
    origin = qoffset;
    info.frame = "lps";
  } else {
    for (std::size_t a = 0; a < 3; ++a) {
      axes[a] = {0, 0, 0};
      axes[a][a] = pixdim[a + 1];
    }
  }
  if (info.frame == "lps") {
    for (auto& v : axes) v = {-v[0], -v[1], v[2]};
    origin = {-origin[0], -origin[1], origin[2]};
  }
  setGeometry(info, axes, origin, axesField, originField);
  // Data: in the same file after vox_offset, or in the .img beside a .hdr.
  layout.compression = Compression::kAutoGzip;
  if (endsWith(path, ".hdr") || endsWith(path, ".hdr.gz")) {
    std::string img = path.substr(0, path.size() - (endsWith(path, ".gz") ? 7 : 4)) + ".img";
    std::error_code ec;
    if (!fs::exists(img, ec) && fs::exists(img + ".gz", ec)) img += ".gz";
    layout.files = {img};
  } else {
    layout.files = {path};
    // vox_offset is a float in NIfTI-1: a whole number of bytes, checked before any cast. The data
    // must follow the header; an offset inside it (0, from some writers) means right after it.
    if (!(voxOffset >= 0 && voxOffset == std::floor(voxOffset) && voxOffset < 0x1p62)) {
      throw Error(fmt::format("{}: NIfTI vox_offset {} is not a byte offset", path, voxOffset));
    }
    layout.skipBytes = static_cast<std::int64_t>(voxOffset);
    if (layout.skipBytes < (version == 1 ? 348 : 540)) layout.skipBytes = version == 1 ? 352 : 544;
  }
  layout.byteOrder =
      swap ? (hostByteOrder() == ByteOrder::kLittle ? ByteOrder::kBig : ByteOrder::kLittle) : hostByteOrder();
  return openVolumeFile(info, layout);
}

}  // namespace

bool isVolumeFormat(const std::string& path) {
  for (const char* ext : {".nrrd", ".nhdr", ".mha", ".mhd", ".nii", ".nii.gz", ".hdr"}) {
    if (endsWith(path, ext)) return true;
  }
  return false;
}

std::unique_ptr<SliceSource> openVolumeFormat(const std::string& path, int channel, std::vector<std::string>* notes,
                                              NiftiXform xform) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(ENOENT)));
  if (endsWith(path, ".nrrd") || endsWith(path, ".nhdr")) return openNrrd(path, channel, notes);
  if (endsWith(path, ".mha") || endsWith(path, ".mhd")) return openMetaImage(path, channel);
  if (channel >= 1) {
    // A NIfTI's fourth axis is a series of volumes (isoslab reads the first), never components.
    throw Error(fmt::format("`channel`: {} has one value per voxel (channel 0 only)", path));
  }
  return openNifti(path, notes, xform);
}

}  // namespace isoslab

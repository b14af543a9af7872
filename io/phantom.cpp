#include "io/phantom.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <set>
#include <vector>

#include "core/error.h"

namespace isoslab {
namespace {

std::vector<std::string> split(std::string_view s, char sep) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t p = s.find(sep, start);
    parts.emplace_back(s.substr(start, p == std::string_view::npos ? s.size() - start : p - start));
    if (p == std::string_view::npos) break;
    start = p + 1;
  }
  return parts;
}

double parseNumber(const std::string& spec, const std::string& key, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
    throw Error(fmt::format("{}: key '{}' has the value '{}', which is not a number", spec, key, text));
  }
  return v;
}

std::array<double, 3> parseTriple(const std::string& spec, const std::string& key, const std::string& text,
                                  bool allowScalar) {
  const auto parts = split(text, ',');
  if (parts.size() == 1 && allowScalar) {
    const double v = parseNumber(spec, key, parts[0]);
    return {v, v, v};
  }
  if (parts.size() != 3) {
    throw Error(fmt::format("{}: key '{}' needs three comma-separated values, got '{}'", spec, key, text));
  }
  return {parseNumber(spec, key, parts[0]), parseNumber(spec, key, parts[1]), parseNumber(spec, key, parts[2])};
}

// A deterministic hash of a lattice point, so that noise does not depend on reading order.
std::uint64_t mix(std::uint64_t x) noexcept {
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  x ^= x >> 31;
  return x;
}

// Approximately standard normal noise: the sum of four uniforms, rescaled to unit variance.
double gaussianNoise(std::uint64_t seed, std::int64_t i, std::int64_t j, std::int64_t k) noexcept {
  std::uint64_t h =
      mix(seed * 0x9e3779b97f4a7c15ULL ^
          mix(static_cast<std::uint64_t>(i) ^ mix(static_cast<std::uint64_t>(j) ^ mix(static_cast<std::uint64_t>(k)))));
  double sum = 0;
  for (int n = 0; n < 4; ++n) {
    h = mix(h + 0x9e3779b97f4a7c15ULL);
    sum += static_cast<double>(h >> 11) * 0x1.0p-53;
  }
  return (sum - 2.0) * std::sqrt(3.0);
}

// 1 deep inside, 0 outside, a linear ramp one voxel wide across the surface; `d` is a signed
// distance in voxels, negative inside.
double cover(double d) noexcept {
  return std::clamp(0.5 - d, 0.0, 1.0);
}

// Approximate signed distance in voxels to an axis-aligned ellipsoid with semi-axes `a`.
double ellipsoidDistance(double x, double y, double z, const std::array<double, 3>& a) noexcept {
  const double q = std::sqrt((x * x) / (a[0] * a[0]) + (y * y) / (a[1] * a[1]) + (z * z) / (a[2] * a[2]));
  return (q - 1.0) * std::min({a[0], a[1], a[2]});
}

}  // namespace

bool PhantomSource::isPhantom(std::string_view input) noexcept {
  return input.substr(0, 8) == "phantom:";
}

std::unique_ptr<PhantomSource> PhantomSource::open(const std::string& spec) {
  if (!isPhantom(spec)) throw Error(fmt::format("{}: not a phantom spec (phantom:NAME?key=value&...)", spec));
  const std::string body = spec.substr(8);
  const std::size_t q = body.find('?');
  const std::string name = body.substr(0, q);
  std::map<std::string, std::string> keys;
  if (q != std::string::npos && q + 1 < body.size()) {
    for (const std::string& kv : split(std::string_view(body).substr(q + 1), '&')) {
      const std::size_t eq = kv.find('=');
      if (eq == std::string::npos || eq == 0) {
        throw Error(fmt::format("{}: '{}' is not key=value", spec, kv));
      }
      if (!keys.emplace(kv.substr(0, eq), kv.substr(eq + 1)).second) {
        throw Error(fmt::format("{}: key '{}' is given twice", spec, kv.substr(0, eq)));
      }
    }
  }

  std::unique_ptr<PhantomSource> p(new PhantomSource());
  std::set<std::string> allowed = {"n", "type", "spacing", "c"};
  std::array<std::int64_t, 3> defaultDims{64, 64, 64};
  if (name == "sphere") {
    p->kind_ = Kind::kSphere;
    allowed.insert({"r", "field"});
  } else if (name == "box" || name == "cube") {
    p->kind_ = Kind::kBox;
    allowed.insert({"lo", "hi"});
  } else if (name == "torus") {
    p->kind_ = Kind::kTorus;
    allowed.insert({"R", "r", "field"});
  } else if (name == "head") {
    p->kind_ = Kind::kHead;
    allowed.insert({"seed", "noise"});
    defaultDims = {128, 128, 112};
  } else if (name == "nested") {
    p->kind_ = Kind::kNested;
    allowed.insert({"r"});
  } else if (name == "boxes") {
    p->kind_ = Kind::kBoxes;
    allowed.insert({"count"});
  } else if (name == "checker") {
    p->kind_ = Kind::kChecker;
    allowed.insert({"b", "labels"});
  } else if (name == "voxel") {
    p->kind_ = Kind::kVoxel;
    defaultDims = {5, 5, 5};
  } else if (name == "touch") {
    p->kind_ = Kind::kTouch;
    allowed.insert({"at"});
    defaultDims = {6, 6, 6};
  } else {
    throw Error(
        fmt::format("{}: unknown phantom '{}' (known: sphere, box, torus, head, nested, boxes, checker, "
                    "voxel, touch)",
                    spec, name));
  }
  for (const auto& [k, v] : keys) {
    if (!allowed.contains(k)) {
      std::string list;
      for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw Error(fmt::format("{}: unknown key '{}' for phantom '{}' (known: {})", spec, k, name, list));
    }
  }
  auto get = [&](const std::string& k) -> const std::string* {
    auto it = keys.find(k);
    return it == keys.end() ? nullptr : &it->second;
  };

  VolumeInfo& info = p->info_;
  info.reader = "phantom";
  info.source = spec;
  info.dims = defaultDims;
  if (const auto* n = get("n")) {
    const auto t = parseTriple(spec, "n", *n, true);
    for (int a = 0; a < 3; ++a) {
      if (t[a] != std::floor(t[a]) || std::abs(t[a]) > 2147483647.0) {
        throw Error(fmt::format("{}: key 'n' must hold whole numbers, got '{}'", spec, *n));
      }
      info.dims[a] = static_cast<std::int64_t>(t[a]);
    }
  }
  validateDims(info.dims, spec);
  if (const auto* s = get("spacing")) {
    info.spacing = parseTriple(spec, "spacing", *s, true);
    info.spacingFields = {"key 'spacing'", "key 'spacing'", "key 'spacing'"};
    for (double v : info.spacing) {
      if (!(v > 0)) throw Error(fmt::format("{}: key 'spacing' must be positive, got '{}'", spec, *s));
    }
  }
  for (int a = 0; a < 3; ++a) p->centre_[a] = 0.5 * static_cast<double>(info.dims[a] - 1);
  if (const auto* c = get("c")) p->centre_ = parseTriple(spec, "c", *c, false);
  const double minDim = static_cast<double>(std::min({info.dims[0], info.dims[1], info.dims[2]}));

  std::string field = "distance";
  if (const auto* f = get("field")) {
    field = *f;
    if (field != "distance" && field != "binary") {
      throw Error(fmt::format("{}: key 'field' must be 'distance' or 'binary', got '{}'", spec, field));
    }
  }
  p->binary_ = field == "binary";
  auto positive = [&](const std::string& k, double def) {
    const auto* v = get(k);
    if (v == nullptr) return def;
    const double x = parseNumber(spec, k, *v);
    if (!(x > 0)) throw Error(fmt::format("{}: key '{}' must be positive, got '{}'", spec, k, *v));
    return x;
  };

  switch (p->kind_) {
    case Kind::kSphere:
    case Kind::kTorus:
      if (p->kind_ == Kind::kSphere) {
        p->radius_ = positive("r", std::floor(0.3 * minDim));
      } else {
        p->majorRadius_ = positive("R", std::floor(0.25 * minDim));
        p->radius_ = positive("r", std::floor(0.1 * minDim));
        if (p->radius_ >= p->majorRadius_) {
          throw Error(fmt::format("{}: the minor radius r must be smaller than R", spec));
        }
      }
      info.type = p->binary_ ? VoxelType::kU8 : VoxelType::kF32;
      info.suggestedIso = p->binary_ ? 50.0 : 1000.0 - 10.0 * p->radius_;
      if (p->binary_) info.valueRange = std::array<double, 2>{0.0, 100.0};
      if (p->kind_ == Kind::kSphere) info.sphere = AnalyticSphere{p->centre_, p->radius_};
      break;
    case Kind::kBox: {
      for (int a = 0; a < 3; ++a) {
        p->lo_[a] = info.dims[a] / 3;
        p->hi_[a] = info.dims[a] - 1 - info.dims[a] / 3;
      }
      for (const char* k : {"lo", "hi"}) {
        if (const auto* v = get(k)) {
          const auto t = parseTriple(spec, k, *v, false);
          auto& dst = std::string(k) == "lo" ? p->lo_ : p->hi_;
          for (int a = 0; a < 3; ++a) dst[a] = static_cast<std::int64_t>(std::llround(t[a]));
        }
      }
      for (int a = 0; a < 3; ++a) {
        if (p->lo_[a] > p->hi_[a]) throw Error(fmt::format("{}: 'lo' must not exceed 'hi'", spec));
      }
      info.type = VoxelType::kU8;
      info.suggestedIso = 50.0;
      info.valueRange = std::array<double, 2>{0.0, 100.0};
      break;
    }
    case Kind::kNested:
      p->radius_ = positive("r", std::floor(0.4 * minDim));
      info.type = VoxelType::kU8;
      info.labelMap = true;
      break;
    case Kind::kBoxes:
      p->count_ = static_cast<std::int64_t>(positive("count", 3));
      if (p->count_ > info.dims[0] || p->count_ > 255) {
        throw Error(fmt::format("{}: key 'count' must be at most the x size and 255", spec));
      }
      info.type = VoxelType::kU8;
      info.labelMap = true;
      break;
    case Kind::kChecker:
      p->block_ = static_cast<std::int64_t>(positive("b", 4));
      p->count_ = static_cast<std::int64_t>(positive("labels", 8));
      if (p->count_ > 65535) throw Error(fmt::format("{}: key 'labels' must be at most 65535", spec));
      info.type = VoxelType::kU16;
      info.labelMap = true;
      break;
    case Kind::kVoxel:
      info.type = VoxelType::kU8;
      info.labelMap = true;
      break;
    case Kind::kTouch: {
      const auto* at = get("at");
      const std::string where = at != nullptr ? *at : "edge";
      if (where != "face" && where != "edge" && where != "corner") {
        throw Error(fmt::format("{}: key 'at' must be 'face', 'edge' or 'corner', got '{}'", spec, where));
      }
      p->count_ = where == "face" ? 1 : where == "edge" ? 2 : 3;  // axes along which the second voxel steps
      info.type = VoxelType::kU8;
      info.labelMap = true;
      break;
    }
    case Kind::kHead:
      info.type = VoxelType::kI16;
      info.suggestedIso = -400.0;
      if (const auto* s = get("seed")) p->seed_ = static_cast<std::uint64_t>(parseNumber(spec, "seed", *s));
      if (const auto* s = get("noise")) {
        p->noise_ = parseNumber(spec, "noise", *s);
        if (p->noise_ < 0) throw Error(fmt::format("{}: key 'noise' must not be negative", spec));
      }
      break;
  }
  if (const auto* t = get("type")) {
    const auto type = parseVoxelType(*t);
    if (!type) throw Error(fmt::format("{}: unknown voxel type '{}' (use u8 i8 u16 i16 u32 i32 f32 f64)", spec, *t));
    info.type = *type;
  }
  return p;
}

double PhantomSource::value(std::int64_t i, std::int64_t j, std::int64_t k) const noexcept {
  const double x = static_cast<double>(i) - centre_[0];
  const double y = static_cast<double>(j) - centre_[1];
  const double z = static_cast<double>(k) - centre_[2];
  switch (kind_) {
    case Kind::kSphere: {
      const double d = std::sqrt(x * x + y * y + z * z);
      if (binary_) return d <= radius_ ? 100.0 : 0.0;
      return 1000.0 - 10.0 * d;
    }
    case Kind::kTorus: {
      const double ring = std::sqrt(x * x + y * y) - majorRadius_;
      const double d = std::sqrt(ring * ring + z * z);
      if (binary_) return d <= radius_ ? 100.0 : 0.0;
      return 1000.0 - 10.0 * d;
    }
    case Kind::kNested: {
      // Label 1 inside r/3, 2 out to 2r/3, 3 out to r: a ball and two shells.
      const double d = std::sqrt(x * x + y * y + z * z);
      return d <= radius_ / 3 ? 1.0 : d <= 2 * radius_ / 3 ? 2.0 : d <= radius_ ? 3.0 : 0.0;
    }
    case Kind::kBoxes: {
      // `count` slabs along x, touching face to face, within the middle half of y and z.
      const std::int64_t ny = info_.dims[1], nz = info_.dims[2];
      if (j < ny / 4 || j >= ny - ny / 4 || k < nz / 4 || k >= nz - nz / 4) return 0.0;
      return 1.0 + static_cast<double>(i * count_ / info_.dims[0]);
    }
    case Kind::kChecker: {
      // Blocks of b voxels filling the volume, labelled 1 .. labels in turn.
      const std::int64_t bx = (info_.dims[0] + block_ - 1) / block_, by = (info_.dims[1] + block_ - 1) / block_;
      const std::int64_t n = i / block_ + bx * (j / block_ + by * (k / block_));
      return 1.0 + static_cast<double>(n % count_);
    }
    case Kind::kVoxel:
      return i == info_.dims[0] / 2 && j == info_.dims[1] / 2 && k == info_.dims[2] / 2 ? 1.0 : 0.0;
    case Kind::kTouch: {
      // Voxel c and voxel c + (1, 1, 0) (edge) or c + (1, 1, 1) (corner) or c + (1, 0, 0) (face).
      const std::int64_t ci = info_.dims[0] / 2 - 1, cj = info_.dims[1] / 2 - 1, ck = info_.dims[2] / 2 - 1;
      if (i == ci && j == cj && k == ck) return 1.0;
      return i == ci + 1 && j == cj + (count_ >= 2 ? 1 : 0) && k == ck + (count_ >= 3 ? 1 : 0) ? 1.0 : 0.0;
    }
    case Kind::kBox:
      return (i >= lo_[0] && i <= hi_[0] && j >= lo_[1] && j <= hi_[1] && k >= lo_[2] && k <= hi_[2]) ? 100.0 : 0.0;
    case Kind::kHead: {
      // Shapes in units of the grid's half extents; +y is the face, +z the top of the head.
      const std::array<double, 3> half{0.5 * static_cast<double>(info_.dims[0] - 1),
                                       0.5 * static_cast<double>(info_.dims[1] - 1),
                                       0.5 * static_cast<double>(info_.dims[2] - 1)};
      // Cover of the ellipsoid centred at (cx, cy, cz) with semi-axes (ax, ay, az).
      auto blob = [&](double cx, double cy, double cz, double ax, double ay, double az) {
        return cover(ellipsoidDistance(x - cx * half[0], y - cy * half[1], z - cz * half[2],
                                       {ax * half[0], ay * half[1], az * half[2]}));
      };
      // Cover of a vertical cylinder through (cx, cy) of radius r, below height top.
      auto column = [&](double cx, double cy, double r, double top) {
        const double dx = x / half[0] - cx, dy = y / half[1] - cy;
        const double radial = (std::sqrt(dx * dx + dy * dy) - r) * std::min(half[0], half[1]);
        return cover(std::max(radial, (z / half[2] - top) * half[2]));
      };
      auto lerp = [](double v, double target, double w) { return v + (target - v) * w; };
      const double skin = std::max({blob(0, 0, 0.15, 0.72, 0.84, 0.74),      // cranium
                                    blob(0, 0.22, -0.32, 0.50, 0.56, 0.45),  // face and jaw
                                    blob(0, 0.86, -0.12, 0.09, 0.14, 0.17),  // nose
                                    blob(0.71, 0, 0, 0.07, 0.13, 0.20),      // ears
                                    blob(-0.71, 0, 0, 0.07, 0.13, 0.20), column(0, -0.05, 0.36, -0.30)});  // neck
      const double skull = blob(0, 0, 0.15, 0.67, 0.79, 0.69);
      const double brain = blob(0, 0, 0.16, 0.61, 0.73, 0.63);
      const double jaw = std::max(0.0, blob(0, 0.24, -0.34, 0.42, 0.48, 0.36) - blob(0, 0.20, -0.30, 0.34, 0.42, 0.30));
      const double spine = column(0, -0.18, 0.09, -0.45);
      const double ventricles =
          std::max(blob(0.10, -0.02, 0.18, 0.05, 0.22, 0.10), blob(-0.10, -0.02, 0.18, 0.05, 0.22, 0.10));
      const double eyes = std::max(blob(0.28, 0.66, 0.02, 0.11, 0.11, 0.11), blob(-0.28, 0.66, 0.02, 0.11, 0.11, 0.11));
      double v = lerp(-1000.0, 40.0, skin);
      v = lerp(v, 700.0, std::max({skull, jaw, spine}));
      v = lerp(v, 35.0, brain);
      v = lerp(v, 5.0, ventricles);
      v = lerp(v, 10.0, eyes);
      return v + noise_ * gaussianNoise(seed_, i, j, k);
    }
  }
  return 0.0;
}

bool PhantomSource::readSlice(std::span<float> slice) {
  if (nextSlice_ >= info_.dims[2]) return false;
  const std::int64_t k = nextSlice_++;
  std::size_t n = 0;
  for (std::int64_t j = 0; j < info_.dims[1]; ++j) {
    for (std::int64_t i = 0; i < info_.dims[0]; ++i) {
      slice[n++] = static_cast<float>(quantize(value(i, j, k), info_.type));
    }
  }
  return true;
}

std::int64_t PhantomSource::skipSlices(std::int64_t n) {
  const std::int64_t count = std::clamp<std::int64_t>(n, 0, info_.dims[2] - nextSlice_);
  nextSlice_ += count;
  return count;
}

}  // namespace isoslab

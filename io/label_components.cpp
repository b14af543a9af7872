#include "io/label_components.h"

#include <fmt/format.h>

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "core/error.h"
#include "core/interrupt.h"

namespace isoslab {
namespace {

constexpr std::uint32_t kNoPart = 0xffffffffu;

// A run of equal values in a row of a plane: voxels x0 .. x1 - 1.
struct Run {
  std::int32_t x0 = 0, x1 = 0;
  float value = 0;
  std::uint32_t part = kNoPart;  // its part, for a label (value != 0)
};

// Walks two rows' runs (each covering the row) in step, calling f(a, b, overlap) for every pair
// that overlaps.
template <class F>
void overlaps(std::span<Run> a, std::span<Run> b, F&& f) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    f(a[i], b[j], std::min(a[i].x1, b[j].x1) - std::max(a[i].x0, b[j].x0));
    const std::int32_t ea = a[i].x1, eb = b[j].x1;
    if (ea <= eb) ++i;
    if (eb <= ea) ++j;
  }
}

// The part numbering of one layer's planes, the same in both passes (the header's comment).
class PartNumbering {
 public:
  PartNumbering(std::int64_t nx, std::int64_t ny, const std::string& what) : nx_(nx), ny_(ny), what_(what) {}

  // Numbers the next plane's runs; join(a, b) is told of two parts that touch (may be null).
  template <class Join>
  void number(const float* plane, Join&& join) {
    std::swap(prev_, cur_);
    std::swap(prevRows_, curRows_);
    cur_.clear();
    curRows_.assign(1, 0);
    for (std::int64_t y = 0; y < ny_; ++y) {
      const float* row = plane + y * nx_;
      for (std::int64_t x = 0; x < nx_;) {
        const float v = row[x];
        std::int64_t e = x + 1;
        while (e < nx_ && row[e] == v) ++e;
        cur_.push_back(Run{static_cast<std::int32_t>(x), static_cast<std::int32_t>(e), v, kNoPart});
        x = e;
      }
      curRows_.push_back(static_cast<std::uint32_t>(cur_.size()));
      const auto take = [&](Run& a, Run& b, std::int32_t) {
        if (a.value != b.value || b.value == 0) return;
        if (b.part == kNoPart) {
          b.part = a.part;
        } else if (b.part != a.part) {
          join(b.part, a.part);
        }
      };
      if (y > 0) overlaps(curRow(y - 1), curRow(y), take);
      if (planes_ > 0) overlaps(prevRow(y), curRow(y), take);
      for (Run& r : curRow(y)) {
        if (r.value != 0 && r.part == kNoPart) {
          if (parts_ == kNoPart - 1) {
            throw Error(fmt::format(
                "{}: the label map has too many components for the component rules (over 4 billion parts)", what_));
          }
          r.part = parts_++;
        }
      }
    }
    ++planes_;
  }

  std::span<Run> curRow(std::int64_t y) { return rowOf(cur_, curRows_, y); }
  std::span<Run> prevRow(std::int64_t y) { return rowOf(prev_, prevRows_, y); }
  std::int64_t planes() const noexcept { return planes_; }
  std::uint32_t parts() const noexcept { return parts_; }

 private:
  static std::span<Run> rowOf(std::vector<Run>& runs, const std::vector<std::uint32_t>& rows, std::int64_t y) {
    return std::span<Run>(runs).subspan(rows[static_cast<std::size_t>(y)],
                                        rows[static_cast<std::size_t>(y) + 1] - rows[static_cast<std::size_t>(y)]);
  }

  std::int64_t nx_, ny_;
  std::string what_;  // the input, in messages
  std::vector<Run> prev_, cur_;
  std::vector<std::uint32_t> prevRows_, curRows_;  // row y's runs: [rows[y], rows[y + 1])
  std::int64_t planes_ = 0;
  std::uint32_t parts_ = 0;
};

std::uint64_t pairKey(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (std::uint64_t{a} << 32) | b;
}

// Faces between two parts (or components) of different labels: a key pairKey(a, b) and a count.
struct Contact {
  std::uint64_t key = 0;
  std::int64_t faces = 0;
};

// Sorts `contacts` by key and sums the counts of equal keys.
void compact(std::vector<Contact>& contacts) {
  std::sort(contacts.begin(), contacts.end(), [](const Contact& a, const Contact& b) { return a.key < b.key; });
  std::size_t out = 0;
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    throwIfInterruptedEvery(i);
    if (out > 0 && contacts[out - 1].key == contacts[i].key) {
      contacts[out - 1].faces += contacts[i].faces;
    } else {
      contacts[out++] = contacts[i];
    }
  }
  contacts.resize(out);
}

// A union-find whose roots are the smallest members, with path halving.
std::uint32_t findRoot(std::vector<std::uint32_t>& parent, std::uint32_t a) {
  while (parent[a] != a) {
    parent[a] = parent[parent[a]];
    a = parent[a];
  }
  return a;
}
void joinRoots(std::vector<std::uint32_t>& parent, std::uint32_t a, std::uint32_t b) {
  a = findRoot(parent, a);
  b = findRoot(parent, b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

}  // namespace

// One layer's numbering and measures.
struct LabelComponentFinder::Layer {
  Layer(std::int64_t nx, std::int64_t ny, const std::string& what) : numbering(nx, ny, what) {}

  PartNumbering numbering;
  // Per part.
  std::vector<std::uint32_t> parent;
  std::vector<std::int32_t> value;
  std::vector<std::int64_t> voxels, faces, backgroundFaces;
  // Faces between parts of different labels: appended (a run of faces between the same two parts
  // once), compacted when they have doubled since the last compaction.
  std::vector<Contact> contacts;
  std::size_t compactAt = std::size_t{1} << 20;
  // After finish(): per part its component (global index), and the components' contacts (keys of
  // component pairs, sorted).
  std::vector<std::uint32_t> componentOf;
  std::vector<Contact> componentContacts;
  std::vector<std::int64_t> componentBackground;  // per component of this layer, from `first`
  std::uint32_t first = 0, end = 0;               // its components' global indices

  void grow() {
    while (parent.size() < numbering.parts()) {
      parent.push_back(static_cast<std::uint32_t>(parent.size()));
      value.push_back(0);
      voxels.push_back(0);
      faces.push_back(0);
      backgroundFaces.push_back(0);
    }
  }

  // A face of `a` against `b` (different values), `n` voxels long.
  void face(const Run& a, const Run& b, std::int64_t n) {
    if (a.value != 0) {
      faces[a.part] += n;
      if (b.value != 0) {
        const std::uint64_t key = pairKey(a.part, b.part);
        if (!contacts.empty() && contacts.back().key == key) {
          contacts.back().faces += n;
        } else {
          contacts.push_back({key, n});
        }
      } else {
        backgroundFaces[a.part] += n;
      }
    }
    if (b.value != 0) {
      faces[b.part] += n;
      if (a.value == 0) backgroundFaces[b.part] += n;
    }
  }
  // A face of `r` on the volume's faces.
  void outside(const Run& r, std::int64_t n) {
    if (r.value == 0) return;
    faces[r.part] += n;
    backgroundFaces[r.part] += n;
  }

  void add(const float* plane, std::int64_t ny, std::int64_t nz, int layer) {
    numbering.number(plane, [this](std::uint32_t a, std::uint32_t b) {
      grow();
      joinRoots(parent, a, b);
    });
    grow();
    const std::int64_t z = numbering.planes() - 1;
    for (std::int64_t y = 0; y < ny; ++y) {
      std::span<Run> row = numbering.curRow(y);
      for (std::size_t k = 0; k < row.size(); ++k) {
        const Run& r = row[k];
        if (r.value != 0) {
          voxels[r.part] += r.x1 - r.x0;
          value[r.part] = layeredLabel(layer, static_cast<std::int32_t>(r.value));
        }
        if (k == 0) outside(r, 1);
        if (k > 0) face(row[k - 1], r, 1);
        if (k + 1 == row.size()) outside(r, 1);
        if (y == 0) outside(r, r.x1 - r.x0);
        if (y + 1 == ny) outside(r, r.x1 - r.x0);
        if (z == 0) outside(r, r.x1 - r.x0);
        if (z + 1 == nz) outside(r, r.x1 - r.x0);
      }
      const auto between = [this](Run& a, Run& b, std::int32_t n) {
        if (a.value != b.value) face(a, b, n);
      };
      if (y > 0) overlaps(numbering.curRow(y - 1), row, between);
      if (z > 0) overlaps(numbering.prevRow(y), row, between);
    }
    if (contacts.size() >= compactAt) {
      compact(contacts);
      compactAt = std::max(compactAt, 2 * contacts.size());
    }
  }
};

LabelComponentFinder::LabelComponentFinder(const VolumeInfo& info, const std::string& what) : info_(info) {
  for (int l = 0; l < info.layers; ++l) layers_.push_back(std::make_unique<Layer>(info.dims[0], info.dims[1], what));
}

LabelComponentFinder::~LabelComponentFinder() = default;

void LabelComponentFinder::addSlice(std::span<const float> slice) {
  const std::int64_t voxels = info_.sliceVoxels();
  for (int l = 0; l < info_.layers; ++l) {
    layers_[static_cast<std::size_t>(l)]->add(slice.data() + l * voxels, info_.dims[1], info_.dims[2], l);
  }
}

std::uint64_t LabelComponentFinder::parts() const noexcept {
  std::uint64_t n = 0;
  for (const auto& layer : layers_) n += layer->numbering.parts();
  return n;
}

void LabelComponentFinder::finish() {
  if (finished_) return;
  finished_ = true;
  for (auto& layer : layers_) {
    Layer& L = *layer;
    L.first = static_cast<std::uint32_t>(components_.size());
    L.componentOf.assign(L.parent.size(), 0);
    // Roots are their components' first parts, so numbering roots in part order numbers the
    // components in the order of their first voxels.
    for (std::uint32_t p = 0; p < L.parent.size(); ++p) {
      throwIfInterruptedEvery(p);
      const std::uint32_t root = findRoot(L.parent, p);
      if (root == p) {
        L.componentOf[p] = static_cast<std::uint32_t>(components_.size());
        components_.push_back(LabelComponent{L.value[p], 0, 0});
        L.componentBackground.push_back(0);
      } else {
        L.componentOf[p] = L.componentOf[root];
      }
      LabelComponent& c = components_[L.componentOf[p]];
      c.voxels += L.voxels[p];
      c.faces += L.faces[p];
      L.componentBackground[L.componentOf[p] - L.first] += L.backgroundFaces[p];
    }
    L.end = static_cast<std::uint32_t>(components_.size());
    // The parts' contacts become the components' (in place), summed by pair.
    for (std::size_t i = 0; i < L.contacts.size(); ++i) {
      throwIfInterruptedEvery(i);
      Contact& c = L.contacts[i];
      c.key = pairKey(L.componentOf[c.key >> 32], L.componentOf[c.key & 0xffffffffu]);
    }
    compact(L.contacts);
    L.componentContacts = std::move(L.contacts);
    L.contacts = {};
    for (auto* v : {&L.voxels, &L.faces, &L.backgroundFaces}) std::vector<std::int64_t>().swap(*v);
    std::vector<std::uint32_t>().swap(L.parent);
  }
}

const std::vector<LabelComponent>& LabelComponentFinder::components() {
  finish();
  return components_;
}

std::vector<bool> selectLabelComponents(const std::vector<LabelComponent>& components,
                                        const LabelComponentRules& rules) {
  std::vector<bool> keep(components.size(), true);
  std::map<std::int32_t, std::vector<std::uint32_t>> byLabel;  // the thresholds' survivors
  for (std::uint32_t i = 0; i < components.size(); ++i) {
    const LabelComponent& c = components[i];
    if (rules.minTriangles && static_cast<std::uint64_t>(2 * c.faces) < *rules.minTriangles) keep[i] = false;
    if (rules.minVolume && static_cast<double>(c.voxels) * rules.voxelVolume < *rules.minVolume) keep[i] = false;
    if (keep[i]) byLabel[c.label].push_back(i);
  }
  if (rules.keepLargest) {
    const auto measure = [&](std::uint32_t i) {
      return rules.largestByVoxels ? components[i].voxels : components[i].faces;
    };
    for (auto& [label, ids] : byLabel) {
      std::stable_sort(ids.begin(), ids.end(),
                       [&](std::uint32_t a, std::uint32_t b) { return measure(a) > measure(b); });
      for (std::size_t k = static_cast<std::size_t>(std::min<std::uint64_t>(*rules.keepLargest, ids.size()));
           k < ids.size(); ++k) {
        keep[ids[k]] = false;
      }
    }
  }
  return keep;
}

LabelRelabelling LabelComponentFinder::relabelling(const std::vector<bool>& keep) const {
  if (!finished_) throw std::logic_error("LabelComponentFinder::relabelling before components()");
  LabelRelabelling out;
  for (std::size_t l = 0; l < layers_.size(); ++l) {
    const Layer& L = *layers_[l];
    const int layer = static_cast<int>(l);
    const auto local = [&](std::uint32_t c) { return c - L.first; };
    // Dropped components that touch go together (groups by union-find over this layer's).
    std::vector<std::uint32_t> group(L.end - L.first);
    std::iota(group.begin(), group.end(), 0u);
    const auto ends = [&](const Contact& c) {
      return std::pair{static_cast<std::uint32_t>(c.key >> 32), static_cast<std::uint32_t>(c.key & 0xffffffffu)};
    };
    for (const Contact& c : L.componentContacts) {
      const auto [a, b] = ends(c);
      if (!keep[a] && !keep[b]) joinRoots(group, local(a), local(b));
    }
    // Each group's faces with the labels around it (the kept components' and the background), as
    // (group, value, faces) summed by group and value.
    struct Around {
      std::uint32_t group;
      std::int32_t value;
      std::int64_t faces;
    };
    std::vector<Around> around;
    for (std::uint32_t c = L.first; c < L.end; ++c) {
      if (!keep[c]) around.push_back({findRoot(group, local(c)), 0, L.componentBackground[local(c)]});
    }
    for (std::size_t i = 0; i < L.componentContacts.size(); ++i) {
      throwIfInterruptedEvery(i);
      const auto [a, b] = ends(L.componentContacts[i]);
      if (keep[a] == keep[b]) continue;
      const std::uint32_t dropped = keep[a] ? b : a, kept = keep[a] ? a : b;
      around.push_back(
          {findRoot(group, local(dropped)), labelValue(components_[kept].label), L.componentContacts[i].faces});
    }
    std::sort(around.begin(), around.end(),
              [](const Around& x, const Around& y) { return std::tie(x.group, x.value) < std::tie(y.group, y.value); });
    // Per group root: the value its voxels take, the one of the most faces (ties: the lower value,
    // which comes first).
    std::vector<std::int32_t> target(group.size(), 0);
    for (std::size_t i = 0; i < around.size();) {
      const std::uint32_t g = around[i].group;
      std::int64_t most = -1;
      while (i < around.size() && around[i].group == g) {
        const std::int32_t value = around[i].value;
        std::int64_t faces = 0;
        for (; i < around.size() && around[i].group == g && around[i].value == value; ++i) faces += around[i].faces;
        if (faces > most) {
          most = faces;
          target[g] = value;
        }
      }
    }
    around = {};
    std::vector<std::int32_t> takes(L.end - L.first);
    for (std::uint32_t c = L.first; c < L.end; ++c) {
      const LabelComponent& comp = components_[c];
      LabelChange& change = out.changes[comp.label];
      ++change.components;
      takes[local(c)] = labelValue(comp.label);
      if (keep[c]) continue;
      ++change.dropped;
      change.voxelsGiven += comp.voxels;
      takes[local(c)] = target[findRoot(group, local(c))];
      out.changes[layeredLabel(layer, takes[local(c)])].voxelsTaken += comp.voxels;
    }
    std::vector<float>& values = out.partValues.emplace_back(L.componentOf.size());
    for (std::size_t p = 0; p < values.size(); ++p) {
      values[p] = static_cast<float>(takes[local(L.componentOf[p])]);
    }
  }
  return out;
}

struct RelabelSource::Planes {
  std::vector<PartNumbering> numbering;
};

RelabelSource::RelabelSource(std::unique_ptr<SliceSource> inner, std::string what, LabelRelabelling relabelling)
    : inner_(std::move(inner)),
      what_(std::move(what)),
      relabelling_(std::move(relabelling)),
      planes_(std::make_unique<Planes>()) {
  const VolumeInfo& in = inner_->info();
  for (int l = 0; l < in.layers; ++l) planes_->numbering.emplace_back(in.dims[0], in.dims[1], what_);
}

RelabelSource::~RelabelSource() = default;

bool RelabelSource::readSlice(std::span<float> slice) {
  if (!inner_->readSlice(slice)) return false;
  const VolumeInfo& in = inner_->info();
  const std::int64_t voxels = in.sliceVoxels();
  for (std::size_t l = 0; l < planes_->numbering.size(); ++l) {
    PartNumbering& numbering = planes_->numbering[l];
    const std::vector<float>& values = relabelling_.partValues[l];
    float* plane = slice.data() + static_cast<std::int64_t>(l) * voxels;
    numbering.number(plane, [](std::uint32_t, std::uint32_t) {});
    if (numbering.parts() > values.size()) {
      throw Error(fmt::format("{}: the input changed between the component rules' two passes", what_));
    }
    for (std::int64_t y = 0; y < in.dims[1]; ++y) {
      for (const Run& r : numbering.curRow(y)) {
        if (r.value == 0 || values[r.part] == r.value) continue;
        std::fill(plane + y * in.dims[0] + r.x0, plane + y * in.dims[0] + r.x1, values[r.part]);
      }
    }
  }
  return true;
}

std::int64_t RelabelSource::skipSlices(std::int64_t n) {
  // The numbering needs every plane: the skipped slices are read.
  std::int64_t skipped = 0;
  scratch_.resize(static_cast<std::size_t>(inner_->info().sliceValues()));
  while (skipped < n && readSlice(scratch_)) ++skipped;
  return skipped;
}

}  // namespace isoslab

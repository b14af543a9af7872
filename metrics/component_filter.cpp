// Keeping some connected components in a second pass (see component_filter.h).
#include "metrics/component_filter.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

#include <fmt/format.h>

#include "core/error.h"

namespace isoslab {
namespace {

double measureOf(const Component& c, ComponentMeasure measure) {
  return measure == ComponentMeasure::kTriangles ? static_cast<double>(c.triangles) : std::abs(c.volume);
}

bool within(const std::array<double, 6>& bounds, const Vec3f& p, double reach) {
  const double c[3] = {p.x, p.y, p.z};
  for (std::size_t a = 0; a < 3; ++a) {
    if (c[a] < bounds[a] - reach || c[a] > bounds[a + 3] + reach) return false;
  }
  return true;
}

}  // namespace

std::string ComponentRules::text() const {
  std::string s;
  const auto add = [&](const std::string& part) { s += (s.empty() ? "" : " ") + part; };
  if (minTriangles) add(fmt::format("--min-triangles {}", *minTriangles));
  if (minVolume) add(fmt::format("--min-volume {}", *minVolume));
  if (seed) add(fmt::format("--seed {},{},{}", seed->x, seed->y, seed->z));
  if (keepLargest) {
    add(fmt::format("--keep-largest {}", *keepLargest));
    if (measure == ComponentMeasure::kVolume) add("--component-measure volume");
  }
  return s;
}

std::vector<bool> selectComponents(const std::vector<Component>& components, const ComponentRules& rules) {
  std::vector<std::size_t> candidates;
  for (std::size_t i = 0; i < components.size(); ++i) {
    const Component& c = components[i];
    if (rules.minTriangles && c.triangles < *rules.minTriangles) continue;
    if (rules.minVolume && std::abs(c.volume) < *rules.minVolume) continue;
    candidates.push_back(i);
  }
  if (rules.seed) {
    const Vec3f& p = *rules.seed;
    const bool reached = std::any_of(components.begin(), components.end(),
                                     [&](const Component& c) { return within(c.bounds, p, rules.seedReach); });
    if (!reached) {
      std::string where = "the surface is empty";
      if (!components.empty()) {
        std::array<double, 6> all = components.front().bounds;
        for (const Component& c : components) {
          for (std::size_t a = 0; a < 3; ++a) {
            all[a] = std::min(all[a], c.bounds[a]);
            all[a + 3] = std::max(all[a + 3], c.bounds[a + 3]);
          }
        }
        where = fmt::format(
            "{} within x {:.6g} .. {:.6g}, y {:.6g} .. {:.6g}, z {:.6g} .. {:.6g}",
            components.size() == 1 ? "the one component lies" : fmt::format("the {} components lie", components.size()),
            all[0], all[3], all[1], all[4], all[2], all[5]);
      }
      throw Error(fmt::format("--seed {},{},{} lies outside every component's bounds (grown by {:.6g}): {}", p.x, p.y,
                              p.z, rules.seedReach, where));
    }
    const auto nearest = std::min_element(candidates.begin(), candidates.end(), [&](std::size_t a, std::size_t b) {
      return components[a].seedDistance < components[b].seedDistance;
    });
    if (nearest != candidates.end()) candidates = {*nearest};
  }
  if (rules.keepLargest) {
    // The N largest of each surface (several iso values in one pass: each its own N).
    std::stable_sort(candidates.begin(), candidates.end(), [&](std::size_t a, std::size_t b) {
      if (components[a].label != components[b].label) return components[a].label < components[b].label;
      const double ma = measureOf(components[a], rules.measure);
      const double mb = measureOf(components[b], rules.measure);
      return ma != mb ? ma > mb : a < b;
    });
    std::vector<std::size_t> largest;
    std::uint64_t rank = 0;  // within its surface
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      if (k > 0 && components[candidates[k]].label != components[candidates[k - 1]].label) rank = 0;
      if (rank++ < *rules.keepLargest) largest.push_back(candidates[k]);
    }
    candidates = std::move(largest);
  }
  std::vector<bool> kept(components.size(), false);
  for (std::size_t i : candidates) kept[i] = true;
  return kept;
}

std::vector<bool> keptParts(const ComponentSink& firstPass, const std::vector<bool>& keptComponents) {
  const std::vector<std::uint32_t>& of = firstPass.partComponents();
  std::vector<bool> kept(of.size(), false);
  for (std::size_t s = 0; s < of.size(); ++s) kept[s] = of[s] < keptComponents.size() && keptComponents[of[s]];
  return kept;
}

ComponentFilterSink::ComponentFilterSink(MeshSink& next, std::vector<bool> keepPart)
    : next_(next), keepPart_(std::move(keepPart)) {
  parts_.labelVertices(true);
}

void ComponentFilterSink::begin(const MeshHeader& header) {
  parts_.begin(header);
  holding_ = false;
  heldIds_.clear();
  previousIds_.clear();
  previousFirst_ = 0;
  nextId_ = 0;
  keptTriangles_ = droppedTriangles_ = 0;
  MeshHeader out = header;
  out.cellVolumes = false;
  next_.begin(out);
}

void ComponentFilterSink::consume(const MeshChunk& chunk) {
  parts_.consume(chunk);  // settles the held chunk's vertices
  if (holding_) emitHeld();
  held_ = chunk;
  holding_ = true;
}

void ComponentFilterSink::finish() {
  parts_.finish();
  if (holding_) emitHeld();
  holding_ = false;
  if (parts_.parts() != keepPart_.size()) {
    throw Error(fmt::format("the input changed between the two passes of the component filter ({} parts, then {})",
                            keepPart_.size(), parts_.parts()));
  }
  next_.finish();
}

// Sends the held chunk on with its kept vertices (now settled) and the triangles that use them.
void ComponentFilterSink::emitHeld() {
  const std::vector<std::uint32_t>& labels = parts_.settledParts();
  assert(parts_.settledFirst() == held_.firstVertex && labels.size() == held_.positions.size());
  std::swap(previousIds_, heldIds_);
  heldIds_.assign(labels.size(), kDropped);
  out_.clear();
  out_.slab = held_.slab;
  out_.firstVertex = nextId_;
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const std::uint32_t part = labels[i];
    if (part == ComponentSink::kNoPart) continue;
    if (part >= keepPart_.size()) {
      throw Error(fmt::format("the input changed between the two passes of the component filter (part {} of {})", part,
                              keepPart_.size()));
    }
    if (!keepPart_[part]) continue;
    heldIds_[i] = nextId_++;
    out_.positions.push_back(held_.positions[i]);
    if (!held_.normals.empty()) out_.normals.push_back(held_.normals[i]);
    if (!held_.boundary.empty()) out_.boundary.push_back(held_.boundary[i]);
  }
  const auto newId = [&](VertexId v) {
    return v >= held_.firstVertex ? heldIds_[v - held_.firstVertex] : previousIds_[v - previousFirst_];
  };
  for (std::size_t n = 0; n < held_.triangles.size(); ++n) {
    const Triangle& t = held_.triangles[n];
    const Triangle mapped{newId(t[0]), newId(t[1]), newId(t[2])};
    // A triangle's vertices are one part's: kept or dropped together.
    if (mapped[0] == kDropped) {
      assert(mapped[1] == kDropped && mapped[2] == kDropped);
      ++droppedTriangles_;
      continue;
    }
    out_.triangles.push_back(mapped);
    if (!held_.faceLabels.empty()) out_.faceLabels.push_back(held_.faceLabels[n]);
    ++keptTriangles_;
  }
  previousFirst_ = held_.firstVertex;
  next_.consume(out_);
}

}  // namespace isoslab

// LabelComponentFinder and RelabelSource (per-label component rules) against a brute force written
// here on whole volumes: 6-connected components by flood fill, their voxels and faces, the rules,
// the groups of dropped components and the label that each group takes, on random label volumes
// of one and two layers; then the relabelled volume streamed (also after a skip), and what the
// rules promise of it.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "core/error.h"
#include "io/label_components.h"
#include "test_support.h"

namespace isoslab {
namespace {

using testing::VectorSource;

// A volume of `layers` planes per slice, as a layered source hands it out.
struct Volume {
  std::array<std::int64_t, 3> dims{};
  int layers = 1;
  std::vector<float> values;  // per slice: layer 0's plane, then layer 1's, ...

  std::int64_t index(int layer, std::int64_t x, std::int64_t y, std::int64_t z) const {
    return ((z * layers + layer) * dims[1] + y) * dims[0] + x;
  }
  std::unique_ptr<VectorSource> source() const {
    auto s = std::make_unique<VectorSource>(dims, values);
    s->mutableInfo().layers = layers;
    return s;
  }
};

// The brute force's components of one layer, in the order of their first voxel.
struct Brute {
  std::vector<LabelComponent> components;
  std::vector<std::int64_t> background;                  // faces with the background or outside
  std::map<std::pair<int, int>, std::int64_t> contacts;  // faces between components
  std::vector<int> of;                                   // per voxel of the layer: its component or -1
};

Brute bruteComponents(const Volume& v, int layer) {
  const auto [nx, ny, nz] = v.dims;
  Brute b;
  b.of.assign(static_cast<std::size_t>(nx * ny * nz), -1);
  const auto at = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    return v.values[static_cast<std::size_t>(v.index(layer, x, y, z))];
  };
  const auto flat = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    return static_cast<std::size_t>((z * ny + y) * nx + x);
  };
  const std::array<std::array<int, 3>, 6> steps{{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}};
  for (std::int64_t z = 0; z < nz; ++z) {
    for (std::int64_t y = 0; y < ny; ++y) {
      for (std::int64_t x = 0; x < nx; ++x) {
        if (at(x, y, z) == 0 || b.of[flat(x, y, z)] >= 0) continue;
        const int id = static_cast<int>(b.components.size());
        const float value = at(x, y, z);
        b.components.push_back(LabelComponent{layeredLabel(layer, static_cast<std::int32_t>(value)), 0, 0});
        b.background.push_back(0);
        std::vector<std::array<std::int64_t, 3>> todo{{x, y, z}};
        b.of[flat(x, y, z)] = id;
        while (!todo.empty()) {
          const auto p = todo.back();
          todo.pop_back();
          ++b.components[static_cast<std::size_t>(id)].voxels;
          for (const auto& s : steps) {
            const std::int64_t qx = p[0] + s[0], qy = p[1] + s[1], qz = p[2] + s[2];
            const bool inside = qx >= 0 && qy >= 0 && qz >= 0 && qx < nx && qy < ny && qz < nz;
            if (inside && at(qx, qy, qz) == value) {
              if (b.of[flat(qx, qy, qz)] < 0) {
                b.of[flat(qx, qy, qz)] = id;
                todo.push_back({qx, qy, qz});
              }
              continue;
            }
            ++b.components[static_cast<std::size_t>(id)].faces;
            if (!inside || at(qx, qy, qz) == 0) ++b.background[static_cast<std::size_t>(id)];
          }
        }
      }
    }
  }
  // Contacts: each face between two components, counted once per pair orientation-free.
  for (std::int64_t z = 0; z < nz; ++z) {
    for (std::int64_t y = 0; y < ny; ++y) {
      for (std::int64_t x = 0; x < nx; ++x) {
        const int a = b.of[flat(x, y, z)];
        if (a < 0) continue;
        for (int k = 0; k < 6; k += 2) {  // +x, +y, +z
          const std::int64_t qx = x + steps[k][0], qy = y + steps[k][1], qz = z + steps[k][2];
          if (qx >= nx || qy >= ny || qz >= nz) continue;
          const int c = b.of[flat(qx, qy, qz)];
          if (c >= 0 && c != a) ++b.contacts[{std::min(a, c), std::max(a, c)}];
        }
      }
    }
  }
  return b;
}

// The rules, by brute force: thresholds, then per label the N largest (ties: the earlier).
std::vector<bool> bruteKeep(const std::vector<LabelComponent>& cs, const LabelComponentRules& r) {
  std::vector<bool> keep(cs.size());
  for (std::size_t i = 0; i < cs.size(); ++i) {
    keep[i] = !(r.minTriangles && static_cast<std::uint64_t>(cs[i].faces * 2) < *r.minTriangles) &&
              !(r.minVolume && static_cast<double>(cs[i].voxels) * r.voxelVolume < *r.minVolume);
  }
  if (!r.keepLargest) return keep;
  std::vector<bool> out = keep;
  for (std::size_t i = 0; i < cs.size(); ++i) {
    if (!keep[i]) continue;
    std::uint64_t larger = 0;  // kept components of its label that come before it
    for (std::size_t j = 0; j < cs.size(); ++j) {
      if (j == i || !keep[j] || cs[j].label != cs[i].label) continue;
      const auto m = [&](std::size_t k) { return r.largestByVoxels ? cs[k].voxels : cs[k].faces; };
      if (m(j) > m(i) || (m(j) == m(i) && j < i)) ++larger;
    }
    out[i] = larger < *r.keepLargest;
  }
  return out;
}

// The relabelled volume, by brute force: dropped components that touch go together, and each
// group takes the label around it that shares the most faces with it (the background and the
// outside as 0; ties: the lower value).
Volume bruteRelabel(const Volume& v, const std::vector<Brute>& layers, const std::vector<bool>& keep) {
  Volume out = v;
  std::size_t offset = 0;
  for (int layer = 0; layer < v.layers; ++layer) {
    const Brute& b = layers[static_cast<std::size_t>(layer)];
    const int n = static_cast<int>(b.components.size());
    const auto kept = [&](int c) { return static_cast<bool>(keep[offset + static_cast<std::size_t>(c)]); };
    std::vector<int> group(static_cast<std::size_t>(n), -1);
    for (int c = 0; c < n; ++c) {
      if (kept(c) || group[static_cast<std::size_t>(c)] >= 0) continue;
      std::vector<int> todo{c};
      group[static_cast<std::size_t>(c)] = c;
      while (!todo.empty()) {
        const int d = todo.back();
        todo.pop_back();
        for (const auto& [pair, faces] : b.contacts) {
          const int e = pair.first == d ? pair.second : pair.second == d ? pair.first : -1;
          if (e >= 0 && !kept(e) && group[static_cast<std::size_t>(e)] < 0) {
            group[static_cast<std::size_t>(e)] = c;
            todo.push_back(e);
          }
        }
      }
    }
    std::map<int, std::map<std::int32_t, std::int64_t>> around;
    for (int c = 0; c < n; ++c) {
      if (!kept(c)) around[group[static_cast<std::size_t>(c)]][0] += b.background[static_cast<std::size_t>(c)];
    }
    for (const auto& [pair, faces] : b.contacts) {
      if (kept(pair.first) == kept(pair.second)) continue;
      const int dropped = kept(pair.first) ? pair.second : pair.first;
      const int other = kept(pair.first) ? pair.first : pair.second;
      around[group[static_cast<std::size_t>(dropped)]]
            [labelValue(b.components[static_cast<std::size_t>(other)].label)] += faces;
    }
    std::map<int, float> takes;
    for (const auto& [g, faces] : around) {
      std::int32_t best = 0;
      std::int64_t most = -1;
      for (const auto& [value, count] : faces) {
        if (count > most) {
          most = count;
          best = value;
        }
      }
      takes[g] = static_cast<float>(best);
    }
    const auto [nx, ny, nz] = v.dims;
    for (std::int64_t z = 0; z < nz; ++z) {
      for (std::int64_t y = 0; y < ny; ++y) {
        for (std::int64_t x = 0; x < nx; ++x) {
          const int c = b.of[static_cast<std::size_t>((z * ny + y) * nx + x)];
          if (c >= 0 && !kept(c)) {
            out.values[static_cast<std::size_t>(v.index(layer, x, y, z))] =
                takes.at(group[static_cast<std::size_t>(c)]);
          }
        }
      }
    }
    offset += static_cast<std::size_t>(n);
  }
  return out;
}

// Random label volumes: noise (many specks), boxes over a background, or boxes over noise.
Volume randomVolume(std::mt19937& rng, int layers) {
  Volume v;
  std::uniform_int_distribution<std::int64_t> dim(1, 9);
  v.dims = {dim(rng), dim(rng), dim(rng)};
  v.layers = layers;
  v.values.assign(static_cast<std::size_t>(v.dims[0] * v.dims[1] * v.dims[2] * layers), 0.0f);
  const int kind = std::uniform_int_distribution<int>(0, 2)(rng);
  const int labels = std::uniform_int_distribution<int>(1, 4)(rng);
  std::uniform_int_distribution<int> label(0, labels);
  if (kind != 1) {
    for (float& f : v.values) f = static_cast<float>(label(rng));
  }
  if (kind != 0) {
    for (int box = 0; box < 6; ++box) {
      const int layer = std::uniform_int_distribution<int>(0, layers - 1)(rng);
      std::array<std::int64_t, 3> lo{}, hi{};
      for (int a = 0; a < 3; ++a) {
        lo[static_cast<std::size_t>(a)] = std::uniform_int_distribution<std::int64_t>(0, v.dims[a] - 1)(rng);
        hi[static_cast<std::size_t>(a)] = std::uniform_int_distribution<std::int64_t>(lo[a], v.dims[a] - 1)(rng);
      }
      const float value = static_cast<float>(label(rng));
      for (std::int64_t z = lo[2]; z <= hi[2]; ++z) {
        for (std::int64_t y = lo[1]; y <= hi[1]; ++y) {
          for (std::int64_t x = lo[0]; x <= hi[0]; ++x)
            v.values[static_cast<std::size_t>(v.index(layer, x, y, z))] = value;
        }
      }
    }
  }
  return v;
}

std::vector<float> streamed(SliceSource& source, std::int64_t skip) {
  std::vector<float> out, slice(static_cast<std::size_t>(source.info().sliceValues()));
  EXPECT_EQ(source.skipSlices(skip), skip);
  while (source.readSlice(slice)) out.insert(out.end(), slice.begin(), slice.end());
  return out;
}

TEST(LabelComponents, MatchBruteForceAndRelabelAsItDoes) {
  std::mt19937 rng(20261205);
  int dropping = 0, shared = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Volume v = randomVolume(rng, trial % 4 == 3 ? 2 : 1);
    SCOPED_TRACE(::testing::Message() << "trial " << trial << " dims " << v.dims[0] << "x" << v.dims[1] << "x"
                                      << v.dims[2] << " layers " << v.layers);
    // The components.
    LabelComponentFinder finder(v.source()->info(), "trial");
    {
      auto source = v.source();
      std::vector<float> slice(static_cast<std::size_t>(source->info().sliceValues()));
      while (source->readSlice(slice)) finder.addSlice(slice);
    }
    std::vector<Brute> brute;
    std::vector<LabelComponent> expected;
    for (int layer = 0; layer < v.layers; ++layer) {
      brute.push_back(bruteComponents(v, layer));
      expected.insert(expected.end(), brute.back().components.begin(), brute.back().components.end());
    }
    const std::vector<LabelComponent>& found = finder.components();
    ASSERT_EQ(found.size(), expected.size());
    for (std::size_t i = 0; i < found.size(); ++i) {
      EXPECT_EQ(found[i].label, expected[i].label) << "component " << i;
      EXPECT_EQ(found[i].voxels, expected[i].voxels) << "component " << i;
      EXPECT_EQ(found[i].faces, expected[i].faces) << "component " << i;
    }
    // The rules.
    LabelComponentRules rules;
    std::uniform_int_distribution<int> pick(0, 3);
    if (pick(rng) != 0) rules.keepLargest = std::uniform_int_distribution<std::uint64_t>(1, 2)(rng);
    rules.largestByVoxels = pick(rng) < 2;
    if (pick(rng) == 0) rules.minTriangles = std::uniform_int_distribution<std::uint64_t>(6, 40)(rng);
    if (pick(rng) == 0) {
      rules.voxelVolume = 0.5;
      rules.minVolume = std::uniform_int_distribution<int>(1, 6)(rng);
    }
    const std::vector<bool> keep = selectLabelComponents(found, rules);
    ASSERT_EQ(keep, bruteKeep(expected, rules));
    dropping += std::count(keep.begin(), keep.end(), false) > 0;
    // The relabelling, streamed whole and after a skip.
    const Volume want = bruteRelabel(v, brute, keep);
    const LabelRelabelling relabelling = finder.relabelling(keep);
    RelabelSource whole(v.source(), "trial", relabelling);
    ASSERT_EQ(streamed(whole, 0), want.values);
    const std::int64_t skip = std::uniform_int_distribution<std::int64_t>(0, v.dims[2] - 1)(rng);
    RelabelSource after(v.source(), "trial", relabelling);
    const std::vector<float> tail = streamed(after, skip);
    ASSERT_TRUE(std::equal(tail.begin(), tail.end(), want.values.end() - static_cast<std::ptrdiff_t>(tail.size())));
    // The counts of the changes.
    std::map<std::int32_t, std::int64_t> before, now;
    for (int layer = 0; layer < v.layers; ++layer) {
      for (std::int64_t z = 0; z < v.dims[2]; ++z) {
        for (std::int64_t i = 0; i < v.dims[0] * v.dims[1]; ++i) {
          const std::size_t k = static_cast<std::size_t>(v.index(layer, i % v.dims[0], i / v.dims[0], z));
          ++before[layeredLabel(layer, static_cast<std::int32_t>(v.values[k]))];
          ++now[layeredLabel(layer, static_cast<std::int32_t>(want.values[k]))];
        }
      }
    }
    for (const auto& [label, change] : relabelling.changes) {
      EXPECT_EQ(before[label] - change.voxelsGiven + change.voxelsTaken, now[label]) << "label " << label;
      if (labelValue(label) != 0 && change.voxelsTaken > 0) ++shared;
    }
    // What the rules promise: every component left holds a kept one, so it meets the thresholds,
    // and no label has more than N.
    for (int layer = 0; layer < v.layers; ++layer) {
      const Brute left = bruteComponents(want, layer);
      std::map<std::int32_t, std::uint64_t> perLabel;
      for (const LabelComponent& c : left.components) {
        ++perLabel[c.label];
        if (rules.minVolume) {
          EXPECT_GE(static_cast<double>(c.voxels) * rules.voxelVolume, *rules.minVolume);
        }
      }
      if (rules.keepLargest) {
        for (const auto& [label, n] : perLabel) EXPECT_LE(n, *rules.keepLargest) << "label " << label;
      }
    }
  }
  // The trials drop components, and dropped groups go to labels as well as the background.
  EXPECT_GT(dropping, 200);
  EXPECT_GT(shared, 50);
}

TEST(LabelComponents, ASecondPassOverOtherDataIsRefused) {
  Volume v;
  v.dims = {4, 1, 2};
  v.values = {1, 0, 1, 0, 0, 0, 0, 0};  // two specks of label 1
  LabelComponentFinder finder(v.source()->info(), "trial");
  std::vector<float> slice(4);
  for (auto s = v.source(); s->readSlice(slice);) finder.addSlice(slice);
  ASSERT_EQ(finder.components().size(), 2u);
  Volume other = v;
  other.values = {1, 0, 1, 0, 0, 1, 0, 1};  // more parts than the first pass numbered
  RelabelSource relabel(other.source(), "seg.nii", finder.relabelling({true, false}));
  std::vector<float> out(4);
  ASSERT_TRUE(relabel.readSlice(out));
  EXPECT_EQ(out, (std::vector<float>{1, 0, 0, 0}));
  try {
    relabel.readSlice(out);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "seg.nii: the input changed between the component rules' two passes");
  }
}

}  // namespace
}  // namespace isoslab

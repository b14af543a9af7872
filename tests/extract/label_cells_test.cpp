// The label complex's cell rule (extract/label_cells.h), checked over every cell of up to four
// labels: each vertex copy carries, for every label, one fan (a single cycle of its quads).
#include "extract/label_cells.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <map>
#include <random>
#include <vector>

#include "core/float_runs.h"

namespace isoslab {
namespace {

int edgeBetween(int a, int b) {
  for (int e = 0; e < 12; ++e) {
    const auto& c = kLabelEdgeCorners[static_cast<std::size_t>(e)];
    if ((c[0] == a && c[1] == b) || (c[0] == b && c[1] == a)) return e;
  }
  return -1;
}

// For one cell: per face, its mesh-edge copies as lists of crossed edges, as the rule defines
// them in words (the test's own reading of label_cells.h, not the library's union-find).
std::vector<std::vector<int>> edgeCopies(const std::array<std::int32_t, 8>& l) {
  std::vector<std::vector<int>> copies;
  for (const auto& f : kLabelFaceCorners) {
    std::array<int, 4> edges{};
    std::array<std::int32_t, 4> v{};
    for (std::size_t k = 0; k < 4; ++k) {
      edges[k] = edgeBetween(f[k], f[(k + 1) % 4]);
      v[k] = l[static_cast<std::size_t>(f[k])];
    }
    int crossed = 0;
    for (std::size_t k = 0; k < 4; ++k) crossed += v[k] != v[(k + 1) % 4];
    const bool evenSame = v[0] == v[2];
    const bool oddSame = v[1] == v[3];
    if (crossed == 4 && (evenSame || oddSame)) {
      // The diagonal that passes through: forced when the other holds two labels; else the one
      // whose label connects first.
      bool evenPasses = evenSame && (!oddSame || connectsBefore(v[0], v[1]));
      if (evenPasses) {  // copies around corners 1 and 3
        copies.push_back({edges[0], edges[1]});
        copies.push_back({edges[2], edges[3]});
      } else {
        copies.push_back({edges[3], edges[0]});
        copies.push_back({edges[1], edges[2]});
      }
    } else if (crossed > 0) {
      std::vector<int> one;
      for (std::size_t k = 0; k < 4; ++k) {
        if (v[k] != v[(k + 1) % 4]) one.push_back(edges[k]);
      }
      copies.push_back(one);
    }
  }
  return copies;
}

bool touches(const std::array<std::int32_t, 8>& l, int e, std::int32_t label) {
  const auto& c = kLabelEdgeCorners[static_cast<std::size_t>(e)];
  return l[static_cast<std::size_t>(c[0])] == label || l[static_cast<std::size_t>(c[1])] == label;
}

// Checks the cell; returns the extra fans that the test's own walk finds (0 where every label has
// one fan per copy).
void checkCell(const std::array<std::int32_t, 8>& l, int& extraFans) {
  extraFans = 0;
  const CellGroups g = groupCell(l);
  const auto copies = edgeCopies(l);
  // Every edge copy lies in one vertex copy, and holds 0 or 2 quads of each label.
  for (const auto& copy : copies) {
    for (int e : copy) ASSERT_EQ(g.edge[static_cast<std::size_t>(e)], g.edge[static_cast<std::size_t>(copy[0])]);
    for (std::int32_t label : l) {
      int n = 0;
      for (int e : copy) n += touches(l, e, label);
      ASSERT_TRUE(n == 0 || n == 2);
    }
  }
  // Per vertex copy and label: the label's quads, linked through the edge copies, form one cycle.
  std::vector<std::int32_t> labels(l.begin(), l.end());
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  for (int q = 0; q < g.count; ++q) {
    for (std::int32_t label : labels) {
      std::map<int, std::vector<int>> links;
      for (const auto& copy : copies) {
        std::vector<int> mine;
        for (int e : copy) {
          if (g.edge[static_cast<std::size_t>(e)] == q && touches(l, e, label)) mine.push_back(e);
        }
        if (mine.size() == 2) {
          links[mine[0]].push_back(mine[1]);
          links[mine[1]].push_back(mine[0]);
        }
      }
      if (links.empty()) continue;
      for (const auto& [e, next] : links) ASSERT_EQ(next.size(), 2u);
      // Walk each cycle: the label's fans at this copy.
      std::map<int, bool> seen;
      int cycles = 0;
      for (const auto& [start, unused] : links) {
        if (seen[start]) continue;
        ++cycles;
        int prev = -1, at = start;
        std::size_t steps = 0;
        do {
          seen[at] = true;
          const auto& n = links[at];
          const int go = n[0] != prev ? n[0] : n[1];
          prev = at;
          at = go;
          ASSERT_LE(++steps, links.size());
        } while (at != start);
      }
      extraFans += cycles - 1;
    }
  }
  // Copies are numbered by their lowest edge.
  int last = -1;
  for (std::size_t e = 0; e < 12; ++e) {
    if (g.edge[e] == 0xff) continue;
    ASSERT_LE(static_cast<int>(g.edge[e]), last + 1);
    last = std::max(last, static_cast<int>(g.edge[e]));
  }
  ASSERT_EQ(last + 1, g.count);
}

// The distinct labels of a cell.
int distinct(const std::array<std::int32_t, 8>& l) {
  int n = 0;
  for (std::size_t c = 0; c < 8; ++c) {
    bool earlier = false;
    for (std::size_t d = 0; d < c; ++d) earlier = earlier || l[d] == l[c];
    n += !earlier;
  }
  return n;
}

TEST(LabelCells, EveryCellOfUpToFourLabelsIsClosedAndPinchesOnlyWhereThreeMeet) {
  std::array<std::int32_t, 8> l{};
  const std::array<std::int32_t, 4> values{0, 3, 7, -2};
  int pinchedCells = 0;
  for (int code = 0; code < 65536; ++code) {
    for (std::size_t c = 0; c < 8; ++c) l[c] = values[static_cast<std::size_t>((code >> (2 * c)) & 3)];
    int extra = 0;
    checkCell(l, extra);
    if (::testing::Test::HasFatalFailure()) {
      ADD_FAILURE() << "cell code " << code;
      return;
    }
    int reported = 0;
    forEachPinch(l, groupCell(l), [&](std::int32_t, int n) { reported += n; });
    ASSERT_EQ(reported, extra) << "cell code " << code;
    if (distinct(l) <= 2) {
      ASSERT_EQ(extra, 0) << "cell code " << code;
    }
    pinchedCells += extra > 0;
  }
  // The pinch of the rule's comment: 3 and 7 in a checkerboard under a layer of 0.
  int pinches = 0;
  forEachPinch({3, 7, 7, 3, 0, 0, 0, 0}, groupCell({3, 7, 7, 3, 0, 0, 0, 0}), [&](std::int32_t label, int n) {
    EXPECT_EQ(label, 7);
    pinches += n;
  });
  EXPECT_EQ(pinches, 1);
  EXPECT_GT(pinchedCells, 0);
}

TEST(LabelCells, TheTwoLabelTableIsTheRule) {
  for (int mask = 0; mask < 256; ++mask) {
    std::array<std::int32_t, 8> l{};
    for (std::size_t c = 0; c < 8; ++c) l[c] = ((mask >> c) & 1) ? 9 : 4;
    const CellGroups a = groupCell(l);
    const CellGroups& b = twoLabelGroups(static_cast<std::uint8_t>(mask));
    EXPECT_EQ(a.count, b.count);
    EXPECT_EQ(a.edge, b.edge);
  }
}

TEST(LabelCells, VoxelsTouchingAtACornerOrAnEdgeSplitTheVertex) {
  // A label at two opposite corners, background elsewhere: two copies of three edges each.
  std::array<std::int32_t, 8> corner{5, 0, 0, 0, 0, 0, 0, 5};
  EXPECT_EQ(groupCell(corner).count, 2);
  // At two corners of a face's diagonal: two copies; the background passes between them.
  std::array<std::int32_t, 8> edge{5, 0, 0, 5, 0, 0, 0, 0};
  EXPECT_EQ(groupCell(edge).count, 2);
  // Background at a face's diagonal inside the label: the background passes through, and the
  // label's two corners of that face join through the face above anyway.
  std::array<std::int32_t, 8> filled{0, 5, 5, 0, 5, 5, 5, 5};
  EXPECT_EQ(groupCell(filled).count, 1);
  // Two labels in a checkerboard of a face (no background): the smaller passes through, so 3's
  // two voxels that touch at an edge split, each surrounded by 2.
  std::array<std::int32_t, 8> two{2, 3, 3, 2, 2, 2, 2, 2};
  EXPECT_EQ(groupCell(two).count, 2);
  // 2 on that diagonal and 3 everywhere else: 2 passes through, and 3 is joined by the upper face.
  std::array<std::int32_t, 8> flat{2, 3, 3, 2, 3, 3, 3, 3};
  EXPECT_EQ(groupCell(flat).count, 1);
  EXPECT_EQ(groupCell({}).count, 0);
}

}  // namespace
}  // namespace isoslab

namespace isoslab {
namespace {

// runEnd and runStart (core/float_runs.h) against a plain scan, on random rows of a few values
// with NaN among them, at every start, end and length (the vector loop and its scalar tail).
TEST(FloatRuns, AgreeWithAPlainScan) {
  std::mt19937 random(7);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<float> row(static_cast<std::size_t>(random() % 40));
    for (float& v : row) {
      const unsigned r = random() % 16;
      v = r == 0 ? nan : static_cast<float>(r % 3);  // long runs of 1 and 2, some 0s and NaNs
    }
    const auto n = static_cast<std::int64_t>(row.size());
    for (std::int64_t from = 0; from <= n; ++from) {
      for (std::int64_t end = from; end <= n; ++end) {
        for (const float v : {0.0f, 1.0f, 2.0f, nan}) {
          std::int64_t forward = from;
          while (forward < end && row[static_cast<std::size_t>(forward)] == v) ++forward;
          ASSERT_EQ(runEnd(row.data(), from, end, v), forward) << trial << " " << from << " " << end;
          std::int64_t back = end - 1;
          while (back >= from && row[static_cast<std::size_t>(back)] == v) --back;
          ASSERT_EQ(runStart(row.data(), from, end, v), back) << trial << " " << from << " " << end;
        }
      }
    }
  }
}

}  // namespace
}  // namespace isoslab

// Marching Cubes: W. E. Lorensen and H. E. Cline, SIGGRAPH 1987; tables generated as described in
// mc_table.h. Tetrahedral cases: tet_table.h.
#include "extract/case_lists.h"

#include <algorithm>
#include <cassert>
#include <stdexcept>
#include <tuple>

#include "extract/mc33_table.h"
#include "extract/mc_table.h"
#include "extract/tet_table.h"

namespace isoslab {
namespace {

bool lowerNode(const LatticeNode& a, const LatticeNode& b) {
  return std::tie(a.hz, a.hy, a.hx) < std::tie(b.hz, b.hy, b.hx);
}

}  // namespace

void CaseList::addCase(unsigned key, const std::vector<std::array<std::uint8_t, 3>>& triangles) {
  CaseSpan& span = cases[key];
  span.firstEdge = static_cast<std::int32_t>(caseEdges.size());
  span.firstTriangle = static_cast<std::int32_t>(caseTriangles.size());
  for (const auto& tri : triangles) {
    std::array<std::uint8_t, 3> local{};
    for (std::size_t c = 0; c < 3; ++c) {
      const auto begin = caseEdges.begin() + span.firstEdge;
      const auto it = std::find(begin, caseEdges.end(), tri[c]);
      local[c] = static_cast<std::uint8_t>(it - begin);
      if (it == caseEdges.end()) caseEdges.push_back(tri[c]);  // may reallocate: index taken first
    }
    caseTriangles.push_back(local);
  }
  span.edgeCount = static_cast<std::uint8_t>(caseEdges.size() - static_cast<std::size_t>(span.firstEdge));
  span.triangleCount = static_cast<std::uint8_t>(triangles.size());
}

// The triangles of node case `key`: the tetrahedra's, in order.
void CaseList::buildCase(unsigned key) {
  std::vector<std::array<std::uint8_t, 3>> triangles;
  for (std::size_t n = 0; n < tets.size(); ++n) {
    const TetRef& t = tets[n];
    unsigned cas = 0;
    for (unsigned k = 0; k < 4; ++k) cas |= ((key >> t.nodes[k]) & 1u) << k;
    const auto& table = tet::kTetCases;
    for (int m = 0; m < table.triangleCount[cas]; ++m) {
      const auto& tri = table.triangles[cas][static_cast<std::size_t>(m)];
      triangles.push_back({tetEdges[n][tri[0]], tetEdges[n][tri[1]], tetEdges[n][tri[2]]});
    }
  }
  addCase(key, triangles);
}

CellCases::CellCases(const CellScheme* scheme, std::int64_t nx, bool mc33) : nx_(nx) {
  if (scheme == nullptr) {
    for (int c = 0; c < 8; ++c) {
      nodes_.push_back({static_cast<std::int8_t>(2 * (c & 1)), static_cast<std::int8_t>(2 * ((c >> 1) & 1)),
                        static_cast<std::int8_t>(2 * ((c >> 2) & 1))});
    }
    for (int e = 0; e < 12; ++e) {
      mc_.edges.push_back(
          makeEdge(mc::kEdgeCorners[static_cast<std::size_t>(e)][0], mc::kEdgeCorners[static_cast<std::size_t>(e)][1]));
    }
    mc_.cases.resize(256);
    const auto& table = mc::kCaseTable;
    for (unsigned c = 0; c < 256; ++c) {
      std::vector<std::array<std::uint8_t, 3>> triangles;
      for (int t = 0; t < table.triangleCount[c]; ++t) {
        const auto& tri = table.triangles[c][static_cast<std::size_t>(t)];
        triangles.push_back(
            {static_cast<std::uint8_t>(tri[0]), static_cast<std::uint8_t>(tri[1]), static_cast<std::uint8_t>(tri[2])});
      }
      mc_.addCase(c, triangles);
    }
    if (mc33) {
      mc33_.edges = mc_.edges;
      for (std::size_t m = 0; m < kMaxCellPoints; ++m) {
        EdgeRef point;
        point.cellOnly = true;
        point.cellPoint = static_cast<std::uint8_t>(1 + m);
        mc33_.edges.push_back(point);
      }
      mc33_.cases.resize(mc33::kKeyCount);
      mc33Points_.resize(mc33::kKeyCount);
    }
  } else {
    nodes_ = scheme->nodes;
    for (const auto& variant : scheme->variants) {
      CaseList v;
      for (const Tetrahedron& t : variant) {
        TetRef r;
        r.nodes = t.nodes;
        const auto& n = nodes_;
        r.volume = signedVolume6(n[t.nodes[0]], n[t.nodes[1]], n[t.nodes[2]], n[t.nodes[3]]) / 48.0;
        for (auto k : t.nodes) v.nodeMask |= 1u << k;
        v.volume += r.volume;
        std::array<std::uint8_t, 6> ids{};
        for (std::size_t e = 0; e < 6; ++e) {
          const int a = t.nodes[tet::kTetEdges[e][0]];
          const int b = t.nodes[tet::kTetEdges[e][1]];
          // Where every cell's tetrahedra stay within the cell, an edge whose middle lies strictly
          // inside the cell belongs to no other cell, and takes no class (no cache slot) at all.
          // (bcc12's tetrahedra reach into the neighbours.)
          const LatticeNode& na = nodes_[static_cast<std::size_t>(a)];
          const LatticeNode& nb = nodes_[static_cast<std::size_t>(b)];
          auto inner = [](int twice) { return twice > 0 && twice < 4; };  // 2 * the middle, half-units
          const bool cellOnly = scheme->values != NodeValues::kNeighbourCentres && inner(na.hx + nb.hx) &&
                                inner(na.hy + nb.hy) && inner(na.hz + nb.hz);
          const EdgeRef edge = makeEdge(a, b, cellOnly);
          auto same = [&](const EdgeRef& o) { return o.a == edge.a && o.b == edge.b; };
          auto it = std::find_if(v.edges.begin(), v.edges.end(), same);
          if (it == v.edges.end()) it = v.edges.insert(v.edges.end(), edge);
          ids[e] = static_cast<std::uint8_t>(it - v.edges.begin());
        }
        v.tetEdges.push_back(ids);
        v.tets.push_back(r);
      }
      v.cases.resize(std::size_t{1} << nodes_.size());
      if (v.edges.size() > kMaxCaseEdges) throw std::logic_error("a cell scheme variant has too many edges");
      variants_.push_back(std::move(v));
    }
  }
  markSharedEdges();
}

// mc33's case `key`, from the generated tables (mc33_table.h): points 0..11 are the cube edges and
// 12 + m the cell points, which are mc33_'s edges in the same order.
static_assert(kMaxCellPoints == static_cast<std::size_t>(mc33::kMaxCellPoints));

void CellCases::buildMc33Case(unsigned key) {
  const mc33::Mc33Case c = mc33::buildCase(key);
  if (c.cellPoints.size() > kMaxCellPoints) throw std::logic_error("an mc33 case has too many cell points");
  std::copy(c.cellPoints.begin(), c.cellPoints.end(), mc33Points_[key].begin());
  mc33_.addCase(key, c.triangles);
}

// Registers the edge between nodes a and b and returns how to find its vertex slot.
EdgeRef CellCases::makeEdge(int a, int b, bool cellOnly) {
  const LatticeNode* na = &nodes_[static_cast<std::size_t>(a)];
  const LatticeNode* nb = &nodes_[static_cast<std::size_t>(b)];
  if (lowerNode(*nb, *na)) {
    std::swap(a, b);
    std::swap(na, nb);
  }
  EdgeRef r;
  r.a = static_cast<std::uint8_t>(a);
  r.b = static_cast<std::uint8_t>(b);
  r.plane = static_cast<std::uint8_t>(na->hz);
  assert(r.plane <= 2);
  r.cellOnly = cellOnly;
  if (cellOnly) return r;
  auto& classes = na->hz == 1 ? oddClasses_ : evenClasses_;
  // mc, mt5, mt6 and bcc12 have one parity per plane; mt24's face centres share planes with
  // corners (slice z: corners and z-face centres) and with cube centres.
  const std::array<int, 5> key{na->hx & 1, na->hy & 1, nb->hx - na->hx, nb->hy - na->hy, nb->hz - na->hz};
  const auto it = classes.emplace(key, classes.size()).first;
  const std::int64_t dx = na->hx >> 1;  // corner offsets 0/2 -> 0/1, centres 1 -> 0, 3 -> 1
  const std::int64_t dy = na->hy >> 1;
  r.edgeClass = it->second;
  r.cell = dy * nx_ + dx;
  return r;
}

void CellCases::markSharedEdges() {
  std::vector<EdgeRef*> edges;
  for (auto& e : mc_.edges) edges.push_back(&e);
  for (auto& e : mc33_.edges) {
    if (e.cellPoint == 0) edges.push_back(&e);
  }
  for (auto& v : variants_) {
    for (auto& e : v.edges) edges.push_back(&e);
  }
  std::vector<bool> onTop(evenClasses_.size(), false);
  for (const EdgeRef* e : edges) {
    if (e->plane == 2 && !e->cellOnly) onTop[e->edgeClass] = true;
  }
  for (EdgeRef* e : edges) {
    if (e->cellOnly) continue;
    e->shared = e->plane == 0 && onTop[e->edgeClass];
    e->stride = static_cast<std::int64_t>((e->plane == 1 ? oddClasses_ : evenClasses_).size());
    e->offset = e->cell * e->stride + static_cast<std::int64_t>(e->edgeClass);
  }
}

}  // namespace isoslab

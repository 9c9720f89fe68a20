#pragma once
// Marching-cubes tables (Lorensen & Cline 1987) in the usual corner and edge numbering (Bourke):
// corner c sits at kCorner[c] in the unit cell; edge e joins kEdgeCorners[e]. Case bit c is set
// when corner c is negative (inside, TSDF < 0).
//
// The tables are derived at compile time from the cube's topology instead of typed in: on each
// face the crossings are joined so that negative corners are kept apart (the choice of the
// standard table, and the same choice on both sides of every face, which is what keeps the mesh
// closed), the joins around the cube form loops, and each loop is fanned into triangles. Every
// triangle is counter-clockwise seen from the positive side.

#include <array>
#include <cstdint>

namespace imufusion::mesh {

inline constexpr std::array<std::array<int, 3>, 8> kCorner = {
    {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}};

inline constexpr std::array<std::array<int, 2>, 12> kEdgeCorners = {{{0, 1},
                                                                     {1, 2},
                                                                     {2, 3},
                                                                     {3, 0},
                                                                     {4, 5},
                                                                     {5, 6},
                                                                     {6, 7},
                                                                     {7, 4},
                                                                     {0, 4},
                                                                     {1, 5},
                                                                     {2, 6},
                                                                     {3, 7}}};

/// Corners of each face, counter-clockwise seen from outside the cell.
inline constexpr std::array<std::array<int, 4>, 6> kFaceCorners = {{
    {0, 3, 2, 1},  // z = 0
    {4, 5, 6, 7},  // z = 1
    {0, 1, 5, 4},  // y = 0
    {3, 7, 6, 2},  // y = 1
    {0, 4, 7, 3},  // x = 0
    {1, 2, 6, 5},  // x = 1
}};

constexpr int kMaxCaseTriangles = 5;

struct CaseTriangles {
  int count = 0;
  std::array<std::array<std::int8_t, 3>, kMaxCaseTriangles> edges{};  // edge indices per triangle
};

struct Tables {
  std::array<std::uint16_t, 256> edge_mask{};  // bit e: edge e is crossed
  std::array<CaseTriangles, 256> triangles{};
};

namespace detail {

constexpr int edge_between(int a, int b) {
  for (int e = 0; e < 12; ++e) {
    if ((kEdgeCorners[e][0] == a && kEdgeCorners[e][1] == b) ||
        (kEdgeCorners[e][0] == b && kEdgeCorners[e][1] == a)) {
      return e;
    }
  }
  return -1;
}

constexpr Tables make_tables() {
  Tables tables;
  for (int cube = 0; cube < 256; ++cube) {
    auto negative = [cube](int corner) { return ((cube >> corner) & 1) != 0; };
    std::uint16_t mask = 0;
    for (int e = 0; e < 12; ++e) {
      if (negative(kEdgeCorners[e][0]) != negative(kEdgeCorners[e][1])) {
        mask = static_cast<std::uint16_t>(mask | (1u << e));
      }
    }
    tables.edge_mask[cube] = mask;

    // next[e]: the crossing that follows e on its loop. Walking a face counter-clockwise from
    // outside, a join runs from a positive-to-negative crossing to the next negative-to-positive
    // one, cutting off the negative corner between them; a loop so directed runs
    // counter-clockwise seen from the positive side.
    std::array<int, 12> next{-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1};
    for (const auto& face : kFaceCorners) {
      std::array<int, 4> crossing{};
      std::array<bool, 4> leaves_positive{};
      int n = 0;
      for (int k = 0; k < 4; ++k) {
        const int a = face[k], b = face[(k + 1) % 4];
        if (negative(a) != negative(b)) {
          crossing[n] = edge_between(a, b);
          leaves_positive[n] = !negative(a);
          ++n;
        }
      }
      for (int j = 0; j < n; ++j) {
        if (leaves_positive[j]) next[crossing[j]] = crossing[(j + 1) % n];
      }
    }

    CaseTriangles& out = tables.triangles[cube];
    std::array<bool, 12> used{};
    for (int start = 0; start < 12; ++start) {
      if (next[start] < 0 || used[start]) continue;
      std::array<int, 12> loop{};
      int length = 0;
      for (int e = start; !used[e]; e = next[e]) {
        used[e] = true;
        loop[length++] = e;
      }
      for (int i = 1; i + 1 < length; ++i) {
        if (out.count == kMaxCaseTriangles) throw "marching cubes case needs more triangles";
        out.edges[out.count++] = {static_cast<std::int8_t>(loop[0]),
                                  static_cast<std::int8_t>(loop[i]),
                                  static_cast<std::int8_t>(loop[i + 1])};
      }
    }
  }
  return tables;
}

}  // namespace detail

/// Evaluated at compile time: a table that breaks an invariant above fails the build.
inline constexpr Tables kTables = detail::make_tables();

}  // namespace imufusion::mesh

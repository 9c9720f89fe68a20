#pragma once
// A mesh as a sorted list of triangles by their vertices (position, normal, colour), so that
// meshes with different vertex numbering and triangle order compare equal when they hold the same
// triangles with the same orientation.

#include <algorithm>
#include <array>
#include <vector>

#include "imufusion/mesh.hpp"

namespace imufusion::test {

// One vertex: x y z nx ny nz r g b.
using SoupVertex = std::array<float, 9>;
using SoupTriangle = std::array<SoupVertex, 3>;

inline SoupVertex soup_vertex(const Mesh& mesh, std::uint32_t v) {
  const Eigen::Vector3f& p = mesh.vertices[v];
  const Eigen::Vector3f& n = mesh.normals[v];
  SoupVertex out{p.x(), p.y(), p.z(), n.x(), n.y(), n.z(), 0, 0, 0};
  if (!mesh.colors.empty()) {
    for (int c = 0; c < 3; ++c) out[static_cast<std::size_t>(6 + c)] = mesh.colors[v][c];
  }
  return out;
}

// Appends the mesh's triangles, each rotated to start at its smallest vertex (the orientation
// kept).
inline void add_to_soup(const Mesh& mesh, std::vector<SoupTriangle>& soup) {
  for (const auto& tri : mesh.triangles) {
    SoupTriangle t{soup_vertex(mesh, tri[0]), soup_vertex(mesh, tri[1]), soup_vertex(mesh, tri[2])};
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    soup.push_back(t);
  }
}

inline std::vector<SoupTriangle> sorted_soup(std::vector<SoupTriangle> soup) {
  std::sort(soup.begin(), soup.end());
  return soup;
}

inline std::vector<SoupTriangle> triangle_soup(const Mesh& mesh) {
  std::vector<SoupTriangle> soup;
  add_to_soup(mesh, soup);
  return sorted_soup(std::move(soup));
}

}  // namespace imufusion::test

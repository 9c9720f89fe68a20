#pragma once
// Triangle meshes extracted from the volume, and their export. World frame, metres.

#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

#include <Eigen/Core>

#include "imufusion/result.hpp"
#include "imufusion/volume.hpp"

namespace imufusion {

struct Mesh {
  std::vector<Eigen::Vector3f> vertices;               // metres, world frame
  std::vector<Eigen::Vector3f> normals;                // unit, one per vertex
  std::vector<std::array<std::uint8_t, 3>> colors;     // RGB per vertex (empty: no colour)
  std::vector<std::array<std::uint32_t, 3>> triangles; // counter-clockwise seen from outside
};

}  // namespace imufusion

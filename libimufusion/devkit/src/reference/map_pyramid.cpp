#include "reference/map_pyramid.hpp"

#include <array>
#include <cmath>

namespace imufusion {
namespace {

MapLevel downsample(const MapLevel& src, float max_jump_fraction) {
  MapLevel dst;
  const int width = src.vertices.width / 2, height = src.vertices.height / 2;
  for (Vec4Image* image : {&dst.vertices, &dst.normals}) {
    image->width = width;
    image->height = height;
    image->data.assign(static_cast<std::size_t>(width) * height, Eigen::Vector4f::Zero());
  }
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::array<std::size_t, 4> block{
          static_cast<std::size_t>(2 * v) * src.vertices.width + 2 * u,
          static_cast<std::size_t>(2 * v) * src.vertices.width + 2 * u + 1,
          static_cast<std::size_t>(2 * v + 1) * src.vertices.width + 2 * u,
          static_cast<std::size_t>(2 * v + 1) * src.vertices.width + 2 * u + 1};
      float nearest = 0;
      for (std::size_t i : block) {
        const Eigen::Vector4f& p = src.vertices.data[i];
        if (p.w() > 0 && src.normals.data[i].w() > 0 && (nearest == 0 || p.z() < nearest))
          nearest = p.z();
      }
      if (nearest <= 0) continue;
      // Sums of (x, y, z, 1): w counts the entries.
      Eigen::Vector4f point = Eigen::Vector4f::Zero(), normal = Eigen::Vector4f::Zero();
      for (std::size_t i : block) {
        const Eigen::Vector4f& p = src.vertices.data[i];
        const Eigen::Vector4f& n = src.normals.data[i];
        if (p.w() > 0 && n.w() > 0 && p.z() - nearest <= max_jump_fraction * nearest) {
          point += p;
          normal += n;
        }
      }
      const float length =
          std::sqrt(normal.x() * normal.x() + normal.y() * normal.y() + normal.z() * normal.z());
      if (length <= 0) continue;
      const std::size_t out = static_cast<std::size_t>(v) * width + u;
      dst.vertices.data[out] = point / point.w();
      dst.normals.data[out] =
          Eigen::Vector4f(normal.x() / length, normal.y() / length, normal.z() / length, 1.0f);
    }
  }
  return dst;
}

}  // namespace

std::vector<MapLevel> build_map_pyramid(const Vec4Image& vertices, const Vec4Image& normals,
                                        int levels, float max_jump_fraction) {
  std::vector<MapLevel> pyramid;
  pyramid.push_back({vertices, normals});
  for (int level = 1; level < levels; ++level)
    pyramid.push_back(downsample(pyramid.back(), max_jump_fraction));
  return pyramid;
}

}  // namespace imufusion

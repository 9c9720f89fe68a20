#include "reference/preprocess_reference.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace imufusion::reference {
namespace {

FloatImage blank_depth(int width, int height) {
  FloatImage image;
  image.width = width;
  image.height = height;
  image.data.assign(static_cast<std::size_t>(width) * height, 0.0f);
  return image;
}

Vec4Image blank_vectors(int width, int height) {
  Vec4Image image;
  image.width = width;
  image.height = height;
  image.data.assign(static_cast<std::size_t>(width) * height, Eigen::Vector4f::Zero());
  return image;
}

std::size_t idx(int u, int v, int width) { return static_cast<std::size_t>(v) * width + u; }

}  // namespace

FloatImage depth_to_metres(const DepthImage& raw, double min_depth, double max_depth) {
  auto out = blank_depth(raw.width, raw.height);
  for (std::size_t i = 0; i < raw.data.size(); ++i) {
    const double d = raw.data[i] / raw.depth_scale;
    const bool valid = raw.data[i] != 0 && d >= min_depth && d <= max_depth;
    out.data[i] = valid ? static_cast<float>(d) : 0.0f;
  }
  return out;
}

FloatImage bilateral(const FloatImage& depth, int radius, double sigma_space, double sigma_depth) {
  auto out = blank_depth(depth.width, depth.height);
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const double centre = depth.at(u, v);
      if (centre <= 0) continue;
      double sum = 0, weight = 0;
      for (int y = std::max(0, v - radius); y <= std::min(depth.height - 1, v + radius); ++y) {
        for (int x = std::max(0, u - radius); x <= std::min(depth.width - 1, u + radius); ++x) {
          const double d = depth.at(x, y);
          if (d <= 0) continue;
          const double space = (x - u) * (x - u) + (y - v) * (y - v);
          const double w = std::exp(-space / (2 * sigma_space * sigma_space) -
                                    (d - centre) * (d - centre) / (2 * sigma_depth * sigma_depth));
          sum += w * d;
          weight += w;
        }
      }
      out.data[idx(u, v, depth.width)] = static_cast<float>(sum / weight);
    }
  }
  return out;
}

FloatImage pyramid_down(const FloatImage& depth, double max_jump_fraction) {
  auto out = blank_depth(depth.width / 2, depth.height / 2);
  for (int v = 0; v < out.height; ++v) {
    for (int u = 0; u < out.width; ++u) {
      const std::array<double, 4> block{depth.at(2 * u, 2 * v), depth.at(2 * u + 1, 2 * v),
                                        depth.at(2 * u, 2 * v + 1), depth.at(2 * u + 1, 2 * v + 1)};
      double nearest = 0;
      for (double d : block)
        if (d > 0 && (nearest == 0 || d < nearest)) nearest = d;
      if (nearest == 0) continue;
      double sum = 0;
      int count = 0;
      for (double d : block) {
        if (d > 0 && d - nearest <= max_jump_fraction * nearest) {
          sum += d;
          ++count;
        }
      }
      out.data[idx(u, v, out.width)] = static_cast<float>(sum / count);
    }
  }
  return out;
}

Vec4Image vertex_map(const FloatImage& depth, const Intrinsics& k) {
  auto out = blank_vectors(depth.width, depth.height);
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const double d = depth.at(u, v);
      if (d <= 0) continue;
      out.data[idx(u, v, depth.width)] =
          Eigen::Vector4d((u - k.cx) / k.fx * d, (v - k.cy) / k.fy * d, d, 1.0).cast<float>();
    }
  }
  return out;
}

Vec4Image normal_map(const Vec4Image& vertices, double max_jump_fraction) {
  auto out = blank_vectors(vertices.width, vertices.height);
  for (int v = 1; v + 1 < vertices.height; ++v) {
    for (int u = 1; u + 1 < vertices.width; ++u) {
      const Eigen::Vector4f& c = vertices.at(u, v);
      if (c.w() <= 0) continue;
      const std::array<Eigen::Vector4f, 4> nb{vertices.at(u - 1, v), vertices.at(u + 1, v),
                                              vertices.at(u, v - 1), vertices.at(u, v + 1)};
      const bool usable = std::all_of(nb.begin(), nb.end(), [&](const Eigen::Vector4f& p) {
        return p.w() > 0 && std::abs(double(p.z()) - c.z()) <= max_jump_fraction * c.z();
      });
      if (!usable) continue;
      const Eigen::Vector3d du = (nb[1] - nb[0]).head<3>().cast<double>();
      const Eigen::Vector3d dv = (nb[3] - nb[2]).head<3>().cast<double>();
      Eigen::Vector3d n = du.cross(dv);
      if (n.norm() <= 0) continue;
      n.normalize();
      if (n.dot(c.head<3>().cast<double>()) > 0) n = -n;
      out.data[idx(u, v, vertices.width)] = Eigen::Vector4d(n.x(), n.y(), n.z(), 1.0).cast<float>();
    }
  }
  return out;
}

PreprocessedFrame preprocess(const DepthImage& raw, const Intrinsics& intrinsics,
                             const PreprocessConfig& config, int first_map_level) {
  PreprocessedFrame frame;
  frame.raw_depth = depth_to_metres(raw, config.min_depth, config.max_depth);
  // Unfiltered down to the filter's level, filtered there, reduced from it below.
  frame.depth.push_back(frame.raw_depth);
  for (int level = 1; level <= first_map_level; ++level)
    frame.depth.push_back(pyramid_down(frame.depth.back(), config.max_jump_fraction));
  frame.depth.back() = bilateral(
      frame.depth.back(), bilateral_radius_at_level(config, first_map_level),
      bilateral_sigma_space_at_level(config, first_map_level), config.bilateral_sigma_depth);
  for (int level = first_map_level + 1; level < config.levels; ++level)
    frame.depth.push_back(pyramid_down(frame.depth.back(), config.max_jump_fraction));
  frame.vertices.resize(static_cast<std::size_t>(config.levels));
  frame.normals.resize(static_cast<std::size_t>(config.levels));
  for (int level = first_map_level; level < config.levels; ++level) {
    const auto l = static_cast<std::size_t>(level);
    frame.vertices[l] = vertex_map(frame.depth[l], intrinsics.at_level(level));
    frame.normals[l] = normal_map(frame.vertices[l], config.max_jump_fraction);
  }
  return frame;
}

}  // namespace imufusion::reference

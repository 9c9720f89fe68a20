#pragma once
// Pictures of the fused model for people to look at: the raycast coloured and shaded
// (model_picture), a 2x supersampled raycast brought down to size (downsample_2x), and the
// camera's path drawn over an image (draw_path).

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "imufusion/fusion.hpp"
#include "imufusion/types.hpp"

namespace imufusion::tools {

using Rgb = std::array<std::uint8_t, 3>;
inline constexpr Rgb kTrackedPathColor = {0, 220, 255};  // cyan: poses tracking gave
inline constexpr Rgb kLostPathColor = {255, 40, 200};    // magenta: lost, dead-reckoned poses

// One pose of the camera's path: its position (world, metres) and whether tracking gave it
// (false: lost, dead-reckoned or recovering).
struct PathPoint {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  bool tracked = true;
};

// The raycast as a picture: where the surface has fused colour, that colour modulated by the
// Lambertian shading (so shape still shows); elsewhere the shading with an ambient floor of 48
// (surfaces seen from behind or edge-on stay visible); black where no ray hit.
inline ColorImage model_picture(const RaycastImages& r) {
  ColorImage out;
  out.width = r.shaded.width;
  out.height = r.shaded.height;
  out.data.assign(r.shaded.data.size(), 0);
  const bool has_color = r.color.data.size() == r.shaded.data.size();
  for (std::size_t i = 0; i < out.data.size(); i += 3) {
    if (r.vertices.data.size() * 3 == out.data.size() && r.vertices.data[i / 3].w() < 0.5f)
      continue;  // no hit
    const std::uint8_t* s = &r.shaded.data[i];
    const std::uint8_t* c = has_color ? &r.color.data[i] : nullptr;
    if (c == nullptr || (c[0] == 0 && c[1] == 0 && c[2] == 0)) {
      for (int ch = 0; ch < 3; ++ch)
        out.data[i + ch] = static_cast<std::uint8_t>(48 + s[ch] * 207 / 255);
      continue;
    }
    const double light = (s[0] + s[1] + s[2]) / (3.0 * 255.0);
    const double gain = 0.35 + 0.75 * light;  // facing the light: the colour, a little brighter
    for (int ch = 0; ch < 3; ++ch)
      out.data[i + ch] = static_cast<std::uint8_t>(std::min(255.0, c[ch] * gain + 0.5));
  }
  return out;
}

// Halves an image's size, each pixel the mean of the 2x2 it covers (odd last rows and columns
// are dropped): anti-aliasing for a raycast made at twice the size.
inline ColorImage downsample_2x(const ColorImage& in) {
  ColorImage out;
  out.width = in.width / 2;
  out.height = in.height / 2;
  out.data.resize(static_cast<std::size_t>(out.width) * out.height * 3);
  const auto at = [&](int u, int v, int ch) {
    return static_cast<int>(in.data[(static_cast<std::size_t>(v) * in.width + u) * 3 + ch]);
  };
  for (int v = 0; v < out.height; ++v) {
    for (int u = 0; u < out.width; ++u) {
      for (int ch = 0; ch < 3; ++ch) {
        const int sum = at(2 * u, 2 * v, ch) + at(2 * u + 1, 2 * v, ch) + at(2 * u, 2 * v + 1, ch) +
                        at(2 * u + 1, 2 * v + 1, ch);
        out.data[(static_cast<std::size_t>(v) * out.width + u) * 3 + ch] =
            static_cast<std::uint8_t>((sum + 2) / 4);
      }
    }
  }
  return out;
}

// Paints a disc of radius `radius` (pixels) centred at (x, y) in `color`; clipped to the image.
inline void fill_disc(ColorImage& img, double x, double y, double radius, const Rgb& color) {
  const int u0 = std::max(0, static_cast<int>(std::floor(x - radius)));
  const int u1 = std::min(img.width - 1, static_cast<int>(std::ceil(x + radius)));
  const int v0 = std::max(0, static_cast<int>(std::floor(y - radius)));
  const int v1 = std::min(img.height - 1, static_cast<int>(std::ceil(y + radius)));
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      if ((u - x) * (u - x) + (v - y) * (v - y) > radius * radius) continue;
      std::copy(color.begin(), color.end(),
                &img.data[(static_cast<std::size_t>(v) * img.width + u) * 3]);
    }
  }
}

// Draws the camera's path over `img` (made with intrinsics `k` from camera pose
// `T_world_camera`): a line `width` pixels wide between consecutive positions, in
// kTrackedPathColor where the later pose was tracked, kLostPathColor where it was not. Segments
// with an end behind the camera are left out.
inline void draw_path(ColorImage& img, const Intrinsics& k, const Eigen::Isometry3d& T_world_camera,
                      const std::vector<PathPoint>& path, double width = 2.5) {
  const Eigen::Isometry3d T_camera_world = T_world_camera.inverse();
  const auto project = [&](const Eigen::Vector3d& p_world, Eigen::Vector2d& px) {
    const Eigen::Vector3d p = T_camera_world * p_world;
    if (p.z() <= 1e-6) return false;
    px = {k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy};
    return true;
  };
  for (std::size_t i = 1; i < path.size(); ++i) {
    Eigen::Vector2d a, b;
    if (!project(path[i - 1].position, a) || !project(path[i].position, b)) continue;
    const Rgb& color = path[i].tracked ? kTrackedPathColor : kLostPathColor;
    // An end far outside the image: left out (this also bounds the steps below).
    const double limit = 4.0 * (img.width + img.height);
    if (a.cwiseAbs().maxCoeff() > limit || b.cwiseAbs().maxCoeff() > limit) continue;
    const int steps = std::max(1, static_cast<int>(std::ceil(2.0 * (b - a).norm())));
    for (int s = 0; s <= steps; ++s) {
      const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(s) / steps);
      fill_disc(img, p.x(), p.y(), 0.5 * width, color);
    }
  }
}

}  // namespace imufusion::tools

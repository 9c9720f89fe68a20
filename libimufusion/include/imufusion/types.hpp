#pragma once
// Plain data shared by every module. Units: metres, seconds, rad/s, m/s^2, pixels.
// Frames: a transform `T_a_b` maps b-coordinates into a (T_world_camera: camera -> world).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "imufusion/image_view.hpp"

namespace imufusion {

/// Pinhole intrinsics of the depth image, in pixels (ETH3D / TUM convention: pixel centres at
/// integer coordinates, u right, v down).
struct Intrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
  /// Lens distortion of the frames as given, OpenCV's order k1, k2, p1, p2, k3 (Brown-Conrady on
  /// normalized coordinates); all 0 (the default): an ideal pinhole. Frames with distortion are
  /// resampled to the pinhole (fx, fy, cx, cy) on arrival, and everything after sees that image.
  std::array<double, 5> distortion = {0, 0, 0, 0, 0};

  bool distorted() const {
    for (double c : distortion)
      if (c != 0) return true;
    return false;
  }

  /// The intrinsics of an image downsampled by 2^level (pixel (u, v) of level l covers the
  /// 2^l x 2^l block starting at (2^l u, 2^l v) of level 0).
  Intrinsics at_level(int level) const;
};

/// A 16-bit depth image: value / depth_scale = metres along the optical axis, 0 = no measurement.
struct DepthImage {
  int width = 0, height = 0;
  double depth_scale = 5000.0;      // raw units per metre
  std::vector<std::uint16_t> data;  // row-major, width * height

  std::uint16_t at(int u, int v) const { return data[static_cast<std::size_t>(v) * width + u]; }
  DepthView view() const {
    DepthView d = DepthView::uint16(data.data(), width, height, depth_scale);
    d.buffer_bytes = data.size() * sizeof(std::uint16_t);
    return d;
  }
  operator DepthView() const { return view(); }  // NOLINT: an image is usable where a view is
};

/// An 8-bit RGB colour image, row-major, 3 bytes per pixel.
struct ColorImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> data;  // width * height * 3

  ColorView view() const {
    return {data.data(), width, height, 0, ColorFormat::kRgb8, data.size()};
  }
  operator ColorView() const { return view(); }  // NOLINT: an image is usable where a view is
};

/// A frame's optional colour: none (nullptr or a null ColorImage*), an image or a view.
class ColorInput {
 public:
  ColorInput(std::nullptr_t = nullptr) {}  // NOLINT: implicit, as the pointer it replaces
  ColorInput(const ColorImage* image) : has_(image != nullptr) {  // NOLINT
    if (image != nullptr) view_ = image->view();
  }
  ColorInput(const ColorView& view) : view_(view), has_(true) {}  // NOLINT
  /// The view, or null for none.
  const ColorView* get() const { return has_ ? &view_ : nullptr; }

 private:
  ColorView view_;
  bool has_ = false;
};

/// A float image (metres for depth maps), row-major; 0 marks an invalid depth.
struct FloatImage {
  int width = 0, height = 0;
  std::vector<float> data;

  float at(int u, int v) const { return data[static_cast<std::size_t>(v) * width + u]; }
};

/// A map of 3-vectors per pixel (vertices in metres, camera frame, or unit normals); w = 1 marks
/// a valid entry, w = 0 an invalid one. Layout matches the GPU's std430 vec4 arrays.
struct Vec4Image {
  int width = 0, height = 0;
  std::vector<Eigen::Vector4f> data;

  const Eigen::Vector4f& at(int u, int v) const {
    return data[static_cast<std::size_t>(v) * width + u];
  }
};

/// One IMU sample in the IMU frame: gyroscope (rad/s) and accelerometer specific force (m/s^2).
struct ImuSample {
  double timestamp = 0;  // seconds
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();
};

/// A pose at an instant: T_world_camera (camera-to-world), as in TUM ground truth.
struct StampedPose {
  double timestamp = 0;  // seconds
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
};

using Trajectory = std::vector<StampedPose>;

}  // namespace imufusion

// CPU ray casting of a Scene into depth and colour images, and the depth sensor models (Kinect v1,
// phone time-of-flight).

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <thread>

#include "imufusion/synth.hpp"
#include "synth/random.hpp"
#include "synth/scene_internal.hpp"

namespace imufusion::synth {

namespace {

/// Everything the sensor model and shading need per pixel.
struct PixelHit {
  double z = 0.0;           // metres along the optical axis, 0 = nothing hit
  float cos_incidence = 0;  // |cos| of the angle between the ray and the surface normal
  float reflectance = 0;    // mean of the albedo's channels
  int primitive = -1;
  Eigen::Vector3f shade = Eigen::Vector3f::Zero();  // shaded colour in [0, 1]
};

// A light near the ceiling, world frame (metres); Lambertian shading plus an ambient term.
const Eigen::Vector3d kLightPosition(3.0, 2.5, 2.8);
constexpr float kAmbient = 0.35f;

Eigen::Vector3f shade(const RayHit& hit) {
  const Eigen::Vector3d to_light = (kLightPosition - hit.point).normalized();
  const float diffuse = static_cast<float>(std::max(0.0, hit.normal.dot(to_light)));
  return hit.albedo * (kAmbient + (1.0f - kAmbient) * diffuse);
}

int render_threads(int rows) {
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  return std::clamp(static_cast<int>(std::min(hw, 8u)), 1, std::max(1, rows / 8));
}

/// Casts one ray per pixel through the pixel centre. Rows are split over threads; the result
/// does not depend on the split (no randomness here).
std::vector<PixelHit> cast_pixels(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                                  const Intrinsics& k, bool with_shade) {
  const PreparedScene prepared = prepare(scene);
  std::vector<PixelHit> pixels(static_cast<std::size_t>(k.width) * k.height);
  const Eigen::Matrix3d R = T_world_camera.linear();
  const Eigen::Vector3d origin = T_world_camera.translation();
  auto rows = [&](int v_begin, int v_end) {
    for (int v = v_begin; v < v_end; ++v) {
      for (int u = 0; u < k.width; ++u) {
        // Camera ray with unit z: the ray parameter of a hit is its z-depth.
        const Eigen::Vector3d d_cam((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
        const Eigen::Vector3d d = R * d_cam;
        const std::optional<RayHit> hit = intersect(prepared, origin, d);
        if (!hit) continue;
        PixelHit& p = pixels[static_cast<std::size_t>(v) * k.width + u];
        p.z = hit->t;
        p.cos_incidence = static_cast<float>(std::abs(hit->normal.dot(d)) / d.norm());
        p.reflectance = hit->albedo.mean();
        p.primitive = hit->primitive;
        if (with_shade) p.shade = shade(*hit);
      }
    }
  };
  const int threads = render_threads(k.height);
  std::vector<std::thread> workers;
  for (int i = 1; i < threads; ++i) {
    workers.emplace_back(rows, k.height * i / threads, k.height * (i + 1) / threads);
  }
  rows(0, k.height / threads);
  for (std::thread& w : workers) w.join();
  return pixels;
}

/// For a pixel next to a depth discontinuity (a 4-neighbour on another surface whose depth
/// differs by more than max(2 cm, 3% of z), or on no surface), the depth across it: the
/// neighbour's across the largest jump, or 0 where a neighbour has none. Nothing elsewhere.
/// Contacts (a box on the floor) are continuous and kept.
std::optional<double> depth_across_edge(const std::vector<PixelHit>& px, int w, int h, int u,
                                        int v) {
  const PixelHit& p = px[static_cast<std::size_t>(v) * w + u];
  const double threshold = std::max(0.02, 0.03 * p.z);
  const int du[4] = {1, -1, 0, 0};
  const int dv[4] = {0, 0, 1, -1};
  std::optional<double> across;
  for (int i = 0; i < 4; ++i) {
    const int nu = u + du[i], nv = v + dv[i];
    if (nu < 0 || nv < 0 || nu >= w || nv >= h) continue;
    const PixelHit& n = px[static_cast<std::size_t>(nv) * w + nu];
    if (n.primitive == p.primitive) continue;
    if (n.primitive < 0) return 0.0;
    const double jump = std::abs(n.z - p.z);
    if (jump > threshold && (!across || jump > std::abs(*across - p.z))) across = n.z;
  }
  return across;
}

std::uint16_t quantize(double z, const SensorModel& model) {
  const double raw = std::round(z * model.depth_scale);
  return static_cast<std::uint16_t>(std::clamp(raw, 1.0, 65535.0));
}

/// The window's half width at this image's size (noise_window px at 640 wide).
int noise_radius(const Intrinsics& k, const SensorModel& model) {
  const double scaled = (std::max(1, model.noise_window) - 1) * 0.5 * k.width / 640.0;
  return std::max(0, static_cast<int>(std::lround(scaled)));
}

/// Unit-variance noise per pixel for the Kinect model: white noise averaged over the window
/// (2r+1 px square, drawn over the image and a border of r), or one independent draw per pixel
/// in raster order when r is 0.
std::vector<double> kinect_noise(const Intrinsics& k, const SensorModel& model, Rng& rng) {
  const int r = noise_radius(k, model);
  const int w = k.width + 2 * r, h = k.height + 2 * r;
  std::vector<double> white(static_cast<std::size_t>(w) * h);
  for (double& n : white) n = rng.normal();
  if (r == 0) return white;
  std::vector<double> rows(static_cast<std::size_t>(k.width) * h, 0.0);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < k.width; ++u) {
      double sum = 0.0;
      for (int i = 0; i <= 2 * r; ++i) sum += white[static_cast<std::size_t>(v) * w + u + i];
      rows[static_cast<std::size_t>(v) * k.width + u] = sum;
    }
  }
  std::vector<double> field(static_cast<std::size_t>(k.width) * k.height);
  const double norm = 1.0 / (2 * r + 1);  // the sum of (2r+1)^2 unit draws has sd 2r+1
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      double sum = 0.0;
      for (int i = 0; i <= 2 * r; ++i) sum += rows[static_cast<std::size_t>(v + i) * k.width + u];
      field[static_cast<std::size_t>(v) * k.width + u] = sum * norm;
    }
  }
  return field;
}

/// Kinect v1 depth of true depth z with unit noise `noise`: the disparity's error brings the
/// total, its steps included, to depth_noise_sigma(z); the disparity is quantized.
double kinect_noisy_depth(double z, double noise, const SensorModel& model) {
  const double sigma = depth_noise_sigma(z);
  if (model.disparity_step <= 0.0) return z + noise * sigma;
  const double step = disparity_depth_step(z, model);
  const double sigma_below_steps = std::sqrt(std::max(0.0, sigma * sigma - step * step / 12.0));
  const double bf = model.baseline_focal;
  const double disparity = bf / z + noise * sigma_below_steps * bf / (z * z);
  const double steps = std::max(1.0, std::round(disparity / model.disparity_step));
  return bf / (steps * model.disparity_step);
}

/// Kinect v1: no depth at depth edges, kinect_noisy_depth.
std::uint16_t kinect_depth(const std::vector<PixelHit>& px, const Intrinsics& k,
                           const SensorModel& model, int u, int v, double noise) {
  const PixelHit& p = px[static_cast<std::size_t>(v) * k.width + u];
  if (model.edge_dropout && depth_across_edge(px, k.width, k.height, u, v)) return 0;
  if (!model.depth_noise) return quantize(p.z, model);
  return quantize(kinect_noisy_depth(p.z, noise, model), model);
}

/// Phone ToF: no depth where the amplitude is weak; at depth edges a flying pixel or none
/// (`mix` uniform in [0, 1) decides); tof_noise_sigma.
std::uint16_t tof_depth(const std::vector<PixelHit>& px, const Intrinsics& k,
                        const SensorModel& model, int u, int v, double noise, double mix) {
  const PixelHit& p = px[static_cast<std::size_t>(v) * k.width + u];
  if (p.reflectance * p.cos_incidence / (p.z * p.z) < model.min_amplitude) return 0;
  double z = p.z;
  if (model.edge_dropout) {
    if (const std::optional<double> across = depth_across_edge(px, k.width, k.height, u, v)) {
      if (*across <= 0.0 || mix >= kFlyingPixelShare) return 0;
      // The far surface's share of the footprint, uniform in [0, 0.5).
      z += (mix / kFlyingPixelShare) * 0.5 * (*across - p.z);
    }
  }
  if (model.depth_noise) z += noise * tof_noise_sigma(z, p.reflectance, p.cos_incidence);
  if (z < model.min_depth || z > model.max_depth) return 0;
  return quantize(z, model);
}

DepthImage apply_sensor_model(const std::vector<PixelHit>& px, const Intrinsics& k,
                              const SensorModel& model, std::uint64_t seed) {
  DepthImage depth;
  depth.width = k.width;
  depth.height = k.height;
  depth.depth_scale = model.depth_scale;
  depth.data.assign(px.size(), 0);
  const float min_cos =
      static_cast<float>(std::cos(model.max_incidence_deg * std::numbers::pi / 180.0));
  const bool tof = model.kind == SensorKind::kPhoneToF;
  Rng rng(seed);
  const std::vector<double> kinect_field =
      tof ? std::vector<double>{} : kinect_noise(k, model, rng);
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * k.width + u;
      // The same draws per pixel whatever happens to it, so that noise stays aligned across
      // images.
      const double noise = tof ? rng.normal() : kinect_field[i];
      const double mix = tof ? rng.uniform() : 0.0;
      const PixelHit& p = px[i];
      if (p.primitive < 0 || p.z < model.min_depth || p.z > model.max_depth) continue;
      if (p.cos_incidence < min_cos) continue;
      depth.data[i] =
          tof ? tof_depth(px, k, model, u, v, noise, mix) : kinect_depth(px, k, model, u, v, noise);
    }
  }
  return depth;
}

ColorImage to_color(const std::vector<PixelHit>& px, const Intrinsics& k) {
  ColorImage color;
  color.width = k.width;
  color.height = k.height;
  color.data.resize(px.size() * 3);
  for (std::size_t i = 0; i < px.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const float value = std::clamp(px[i].shade[c], 0.0f, 1.0f) * 255.0f;
      color.data[3 * i + c] = static_cast<std::uint8_t>(std::lround(value));
    }
  }
  return color;
}

}  // namespace

Intrinsics default_intrinsics(int width, int height) {
  Intrinsics k;
  const double sx = width / 640.0, sy = height / 480.0;
  k.fx = 525.0 * sx;
  k.fy = 525.0 * sy;
  // Scale about the image corner in pixel-edge coordinates (centres at integer + 0.5 edges).
  k.cx = (319.5 + 0.5) * sx - 0.5;
  k.cy = (239.5 + 0.5) * sy - 0.5;
  k.width = width;
  k.height = height;
  return k;
}

const char* to_string(SensorKind kind) {
  switch (kind) {
    case SensorKind::kKinect:
      return "kinect";
    case SensorKind::kPhoneToF:
      return "phone-tof";
  }
  return "unknown";
}

std::optional<SensorKind> parse_sensor_kind(std::string_view name) {
  for (const SensorKind kind : {SensorKind::kKinect, SensorKind::kPhoneToF}) {
    if (name == to_string(kind)) return kind;
  }
  return std::nullopt;
}

SensorModel sensor_model(SensorKind kind) {
  SensorModel model;
  model.kind = kind;
  if (kind == SensorKind::kPhoneToF) {
    model.min_depth = 0.2;
    model.max_depth = 4.0;
    model.depth_scale = 1000.0;  // DEPTH16: millimetres
    model.min_amplitude = 0.02;
  }
  return model;
}

SensorModel white_noise_model(SensorModel model) {
  model.noise_window = 1;
  model.disparity_step = 0.0;
  return model;
}

SensorFormat sensor_format(SensorKind kind) {
  if (kind == SensorKind::kPhoneToF) return {240, 180, 30.0};
  return {};
}

double depth_noise_sigma(double z) { return 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4); }

double disparity_depth_step(double z, const SensorModel& model) {
  return model.disparity_step > 0.0 ? z * z * model.disparity_step / model.baseline_focal : 0.0;
}

double tof_noise_sigma(double z, double reflectance, double cos_incidence) {
  return 0.01 * z * std::sqrt(0.5 / std::max(0.01, reflectance * cos_incidence));
}

FloatImage raycast_depth(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                         const Intrinsics& intrinsics) {
  const std::vector<PixelHit> px = cast_pixels(scene, T_world_camera, intrinsics, false);
  FloatImage image;
  image.width = intrinsics.width;
  image.height = intrinsics.height;
  image.data.resize(px.size());
  for (std::size_t i = 0; i < px.size(); ++i) image.data[i] = static_cast<float>(px[i].z);
  return image;
}

DepthImage render_depth(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                        const Intrinsics& intrinsics, const SensorModel& model,
                        std::uint64_t seed) {
  return apply_sensor_model(cast_pixels(scene, T_world_camera, intrinsics, false), intrinsics,
                            model, seed);
}

ColorImage render_color(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                        const Intrinsics& intrinsics) {
  return to_color(cast_pixels(scene, T_world_camera, intrinsics, true), intrinsics);
}

RenderedFrame render_frame(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                           const Intrinsics& intrinsics, const SensorModel& model,
                           std::uint64_t seed, bool with_color) {
  const std::vector<PixelHit> px = cast_pixels(scene, T_world_camera, intrinsics, with_color);
  RenderedFrame frame;
  frame.depth = apply_sensor_model(px, intrinsics, model, seed);
  if (with_color) frame.color = to_color(px, intrinsics);
  return frame;
}

}  // namespace imufusion::synth

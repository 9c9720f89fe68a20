#include "reference/volume_reference.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "volume_raycast_rule.h"

namespace imufusion::reference {
namespace {

constexpr double kTsdfScale = 32767.0;  // stored int16 units per truncation unit

double block_length(double voxel_size) { return voxel_size * kBlockSide; }

Eigen::Vector3i floor_div(const Eigen::Vector3d& w, double length) {
  return Eigen::Vector3i(static_cast<int>(std::floor(w.x() / length)),
                         static_cast<int>(std::floor(w.y() / length)),
                         static_cast<int>(std::floor(w.z() / length)));
}

int floor_div_int(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

std::int16_t quantize_tsdf(double tsdf) {
  const double raw = std::clamp(std::round(tsdf * kTsdfScale), -kTsdfScale, kTsdfScale);
  return static_cast<std::int16_t>(raw);
}

std::uint8_t to_unorm8(double x) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(x, 0.0, 1.0) * 255.0));
}

// Raycast images of the camera's size with every pixel a miss (all zero).
RaycastImages blank_raycast_images(const Intrinsics& k) {
  RaycastImages out;
  const auto pixels = static_cast<std::size_t>(k.width) * static_cast<std::size_t>(k.height);
  out.vertices.width = out.normals.width = out.shaded.width = out.color.width = k.width;
  out.vertices.height = out.normals.height = out.shaded.height = out.color.height = k.height;
  out.vertices.data.assign(pixels, Eigen::Vector4f::Zero());
  out.normals.data.assign(pixels, Eigen::Vector4f::Zero());
  out.shaded.data.assign(3 * pixels, 0);
  out.color.data.assign(3 * pixels, 0);
  return out;
}

// Distance (metres) along the ray from `origin` along unit `dir` to where it leaves block b
// (side `length`, metres) through a far face; infinity when dir has no component off zero.
double block_exit(const Eigen::Vector3i& b, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& dir, double length) {
  double t_exit = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(dir[axis]) < 1e-12) continue;
    const double face = (b[axis] + (dir[axis] >= 0.0 ? 1 : 0)) * length;
    t_exit = std::min(t_exit, (face - origin[axis]) / dir[axis]);
  }
  return t_exit;
}

// Pixel `index` of a hit: camera-frame vertex (metres) and unit normal, Lambert shading seen
// from the camera with 0.15 ambient, and the fused colour (0..1).
void write_hit(RaycastImages& out, std::size_t index, const Eigen::Vector3d& vertex,
               const Eigen::Vector3d& normal, const Eigen::Vector3d& rgb) {
  out.vertices.data[index] << vertex.cast<float>(), 1.0f;
  out.normals.data[index] << normal.cast<float>(), 1.0f;
  const double lambert = std::max(0.0, normal.dot(-vertex.normalized()));
  const std::uint8_t shade = to_unorm8(0.15 + 0.85 * lambert);
  for (std::size_t c = 0; c < 3; ++c) {
    out.shaded.data[3 * index + c] = shade;
    out.color.data[3 * index + c] = to_unorm8(rgb[static_cast<Eigen::Index>(c)]);
  }
}

}  // namespace

std::size_t BlockCoordHash::operator()(const Eigen::Vector3i& b) const {
  const auto x = static_cast<std::uint64_t>(static_cast<std::uint32_t>(b.x()));
  const auto y = static_cast<std::uint64_t>(static_cast<std::uint32_t>(b.y()));
  const auto z = static_cast<std::uint64_t>(static_cast<std::uint32_t>(b.z()));
  return static_cast<std::size_t>((x * 0x9E3779B97F4A7C15ull) ^ (y * 0xC2B2AE3D27D4EB4Full) ^
                                  (z * 0x165667B19E3779F9ull));
}

bool block_less(const Eigen::Vector3i& a, const Eigen::Vector3i& b) {
  return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
}

bool block_in_key_range(const Eigen::Vector3i& b) {
  return b.x() >= -1024 && b.x() <= 1023 && b.y() >= -1024 && b.y() <= 1023 && b.z() >= -512 &&
         b.z() <= 511 && b != Eigen::Vector3i(1023, 1023, 511);
}

AllocationResult visible_blocks(const FloatImage& depth, const Intrinsics& k,
                                const Eigen::Isometry3d& T_world_camera, double voxel_size,
                                double truncation) {
  const double length = block_length(voxel_size);
  auto less = [](const Eigen::Vector3i& a, const Eigen::Vector3i& b) { return block_less(a, b); };
  std::set<Eigen::Vector3i, decltype(less)> visible(less);
  AllocationResult result;
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const double d = depth.at(u, v);
      if (!(d > 0.0)) continue;
      const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      const Eigen::Vector3d a = T_world_camera * (ray * std::max(d - truncation, 0.0));
      const Eigen::Vector3d c = T_world_camera * (ray * (d + truncation));
      // Samples at most half a block apart from a to c, both ends included. A segment that
      // only clips the corner of a block can step over it: the definition accepts that.
      const int steps = static_cast<int>(std::ceil((c - a).norm() / (0.5 * length)));
      bool have_last = false;
      Eigen::Vector3i last = Eigen::Vector3i::Zero();
      for (int i = 0; i <= steps; ++i) {
        const double f = static_cast<double>(i) / std::max(steps, 1);
        const Eigen::Vector3i b = floor_div(a + f * (c - a), length);
        if (have_last && b == last) continue;
        have_last = true;
        last = b;
        if (!block_in_key_range(b)) {
          ++result.out_of_range;
          continue;
        }
        visible.insert(b);
      }
    }
  }
  result.visible.assign(visible.begin(), visible.end());
  return result;
}

CpuVolume::CpuVolume(double voxel_size, double truncation, int max_weight)
    : voxel_size_(voxel_size), truncation_(truncation), max_weight_(max_weight) {}

CpuVolume::CpuVolume(const VolumeConfig& config)
    : CpuVolume(config.voxel_size, config.truncation(), config.max_weight) {}

CpuVolume CpuVolume::from_host_volume(const HostVolume& host, int max_weight) {
  CpuVolume volume(host.voxel_size, host.truncation, max_weight);
  for (const VolumeBlock& block : host.blocks) {
    StoredBlock& stored = volume.blocks_[block.coord];
    for (int i = 0; i < kBlockVoxels; ++i) {
      const Voxel& in = block.voxels[static_cast<std::size_t>(i)];
      StoredVoxel& out = stored[static_cast<std::size_t>(i)];
      out.tsdf = quantize_tsdf(in.tsdf);
      out.weight = static_cast<std::uint16_t>(std::lround(in.weight));
      out.color = in.color;
    }
  }
  return volume;
}

AllocationResult CpuVolume::allocate(const FloatImage& depth, const Intrinsics& intrinsics,
                                     const Eigen::Isometry3d& T_world_camera) {
  AllocationResult result =
      visible_blocks(depth, intrinsics, T_world_camera, voxel_size_, truncation_);
  for (const Eigen::Vector3i& b : result.visible) add_block(b);
  return result;
}

void CpuVolume::add_block(const Eigen::Vector3i& b) { blocks_.try_emplace(b); }

void CpuVolume::integrate(const FloatImage& depth, const ColorImage* color, const Intrinsics& k,
                          const Eigen::Isometry3d& T_world_camera,
                          const std::vector<Eigen::Vector3i>& blocks) {
  const Eigen::Isometry3d T_camera_world = T_world_camera.inverse();
  for (const Eigen::Vector3i& b : blocks) {
    auto found = blocks_.find(b);
    if (found == blocks_.end()) continue;
    for (int kz = 0; kz < kBlockSide; ++kz) {
      for (int j = 0; j < kBlockSide; ++j) {
        for (int i = 0; i < kBlockSide; ++i) {
          const Eigen::Vector3i lattice = kBlockSide * b + Eigen::Vector3i(i, j, kz);
          const Eigen::Vector3d p = T_camera_world * (lattice.cast<double>() * voxel_size_);
          if (p.z() <= 0.0) continue;
          // The nearest pixel: pixel u covers [u - 0.5, u + 0.5).
          const double u = std::floor(k.fx * p.x() / p.z() + k.cx + 0.5);
          const double v = std::floor(k.fy * p.y() / p.z() + k.cy + 0.5);
          if (u < 0.0 || v < 0.0 || u >= depth.width || v >= depth.height) continue;
          const auto pixel = static_cast<std::size_t>(v) * static_cast<std::size_t>(depth.width) +
                             static_cast<std::size_t>(u);
          const double d = depth.data[pixel];
          if (!(d > 0.0)) continue;
          const double sdf = d - p.z();
          if (sdf < -truncation_) continue;  // occluded: behind the band
          const double tsdf = std::min(1.0, sdf / truncation_);
          StoredVoxel& voxel = found->second[static_cast<std::size_t>(voxel_index(i, j, kz))];
          const double w = voxel.weight;
          const double old_tsdf = voxel.tsdf / kTsdfScale;
          voxel.tsdf = quantize_tsdf((old_tsdf * w + tsdf) / (w + 1.0));
          voxel.weight = static_cast<std::uint16_t>(std::min(voxel.weight + 1, max_weight_));
          if (color != nullptr) {
            for (std::size_t c = 0; c < 3; ++c) {
              const double mixed =
                  (voxel.color[c] * w + color->data[3 * pixel + c]) / (w + 1.0) / 255.0;
              voxel.color[c] = to_unorm8(mixed);
            }
          }
        }
      }
    }
  }
}

AllocationResult CpuVolume::fuse(const FloatImage& depth, const ColorImage* color,
                                 const Intrinsics& intrinsics,
                                 const Eigen::Isometry3d& T_world_camera) {
  AllocationResult result = allocate(depth, intrinsics, T_world_camera);
  integrate(depth, color, intrinsics, T_world_camera, result.visible);
  return result;
}

const StoredVoxel* CpuVolume::voxel(const Eigen::Vector3i& l) const {
  const Eigen::Vector3i b(floor_div_int(l.x(), kBlockSide), floor_div_int(l.y(), kBlockSide),
                          floor_div_int(l.z(), kBlockSide));
  auto found = blocks_.find(b);
  if (found == blocks_.end()) return nullptr;
  const Eigen::Vector3i i = l - kBlockSide * b;
  return &found->second[static_cast<std::size_t>(voxel_index(i.x(), i.y(), i.z()))];
}

bool CpuVolume::trilinear(const Eigen::Vector3d& g, double* tsdf, Eigen::Vector3d* rgb) const {
  const Eigen::Vector3d base_d = g.array().floor();
  const Eigen::Vector3i base = base_d.cast<int>();
  const Eigen::Vector3d f = g - base_d;
  *tsdf = 0.0;
  if (rgb != nullptr) rgb->setZero();
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3i o(corner & 1, (corner >> 1) & 1, corner >> 2);
    const StoredVoxel* voxel = this->voxel(base + o);
    if (voxel == nullptr || voxel->weight == 0) return false;
    double weight = 1.0;
    for (int axis = 0; axis < 3; ++axis) weight *= o[axis] != 0 ? f[axis] : 1.0 - f[axis];
    *tsdf += weight * (voxel->tsdf / kTsdfScale);
    if (rgb == nullptr) continue;
    for (int c = 0; c < 3; ++c)
      (*rgb)[c] += weight * (voxel->color[static_cast<std::size_t>(c)] / 255.0);
  }
  return true;
}

double CpuVolume::march_ray(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t,
                            double t_far) const {
  const double length = block_length(voxel_size_);
  double previous_tsdf = 0.0, previous_t = 0.0;
  bool have_previous = false;
  while (t < t_far) {
    const Eigen::Vector3d g = (origin + t * dir) / voxel_size_;  // lattice coordinates
    const Eigen::Vector3i b = floor_div(g, kBlockSide);
    if (!contains(b)) {
      // Free or unknown space: leave the block through the face the ray exits by.
      have_previous = false;
      t = std::max(t, block_exit(b, origin, dir, length)) +
          VOLUME_RAYCAST_EXIT_MARGIN * voxel_size_;
      continue;
    }
    const StoredVoxel* nearest = voxel(floor_div(g + Eigen::Vector3d::Constant(0.5), 1.0));
    const bool observed = nearest != nullptr && nearest->weight != 0;
    double tsdf = observed ? nearest->tsdf / kTsdfScale : 0.0;
    if (observed && tsdf * truncation_ >= VOLUME_RAYCAST_COARSE_VOXELS * voxel_size_) {
      // Far in front of the surface: the sample lies within sqrt(3)/2 voxel of the nearest
      // lattice point, so one voxel less than the usual step stays in front of it.
      have_previous = false;
      t += 0.8 * tsdf * truncation_ - voxel_size_;
      continue;
    }
    if (!observed || !trilinear(g, &tsdf, nullptr)) {
      have_previous = false;
      t += (observed ? 0.5 : 1.0) * voxel_size_;
      continue;
    }
    if (have_previous && previous_tsdf > 0.0 && tsdf <= 0.0) {
      // Linear interpolation of the zero crossing between the two samples.
      return previous_t + (t - previous_t) * previous_tsdf / (previous_tsdf - tsdf);
    }
    previous_tsdf = tsdf;
    previous_t = t;
    have_previous = true;
    t += std::max(0.8 * tsdf * truncation_, 0.5 * voxel_size_);
  }
  return -1.0;
}

bool CpuVolume::surface_at(const Eigen::Vector3d& hit, Eigen::Vector3d* gradient,
                           Eigen::Vector3d* rgb) const {
  // Central differences of the trilinear TSDF, one voxel apart.
  const Eigen::Vector3d g_hit = hit / voxel_size_;
  double tsdf_hit = 0.0;
  bool ok = true;
  for (int axis = 0; axis < 3 && ok; ++axis) {
    double plus = 0.0, minus = 0.0;
    ok = trilinear(g_hit + Eigen::Vector3d::Unit(axis), &plus, nullptr) &&
         trilinear(g_hit - Eigen::Vector3d::Unit(axis), &minus, nullptr);
    (*gradient)[axis] = plus - minus;
  }
  return ok && gradient->norm() > 0.0 && trilinear(g_hit, &tsdf_hit, rgb);
}

RaycastImages CpuVolume::raycast(const Intrinsics& k, const Eigen::Isometry3d& T_world_camera,
                                 double near_depth, double far_depth) const {
  RaycastImages out = blank_raycast_images(k);
  const Eigen::Matrix3d R = T_world_camera.linear();
  const Eigen::Vector3d origin = T_world_camera.translation();
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const std::size_t index = static_cast<std::size_t>(v) * static_cast<std::size_t>(k.width) +
                                static_cast<std::size_t>(u);
      const Eigen::Vector3d ray_c((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      const double ray_scale = ray_c.norm();  // metres along the ray per metre of z-depth
      const Eigen::Vector3d dir = R * (ray_c / ray_scale);
      const double hit_t = march_ray(origin, dir, near_depth * ray_scale, far_depth * ray_scale);
      if (hit_t < 0.0) continue;
      const Eigen::Vector3d hit = origin + hit_t * dir;
      Eigen::Vector3d gradient, rgb_hit;
      if (!surface_at(hit, &gradient, &rgb_hit)) continue;
      const Eigen::Vector3d vertex = R.transpose() * (hit - origin);
      const Eigen::Vector3d normal = R.transpose() * gradient.normalized();
      write_hit(out, index, vertex, normal, rgb_hit);
    }
  }
  return out;
}

HostVolume CpuVolume::to_host_volume() const {
  HostVolume host;
  host.voxel_size = static_cast<float>(voxel_size_);
  host.truncation = static_cast<float>(truncation_);
  for (const Eigen::Vector3i& b : block_coords()) {
    VolumeBlock block;
    block.coord = b;
    const StoredBlock& stored = blocks_.at(b);
    for (std::size_t i = 0; i < stored.size(); ++i) {
      block.voxels[i].tsdf = static_cast<float>(stored[i].tsdf / kTsdfScale);
      block.voxels[i].weight = static_cast<float>(stored[i].weight);
      block.voxels[i].color = stored[i].color;
    }
    host.blocks.push_back(block);
  }
  return host;
}

std::vector<Eigen::Vector3i> CpuVolume::block_coords() const {
  std::vector<Eigen::Vector3i> coords;
  coords.reserve(blocks_.size());
  for (const auto& entry : blocks_) coords.push_back(entry.first);
  std::sort(coords.begin(), coords.end(), block_less);
  return coords;
}

}  // namespace imufusion::reference

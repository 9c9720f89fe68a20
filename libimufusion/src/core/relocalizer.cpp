#include "core/relocalizer.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <map>
#include <unordered_set>

namespace imufusion {
namespace {

struct CellHash {
  std::size_t operator()(const Eigen::Vector3i& c) const {
    return (static_cast<std::size_t>(c.x()) * 73856093u) ^
           (static_cast<std::size_t>(c.y()) * 19349663u) ^
           (static_cast<std::size_t>(c.z()) * 83492791u);
  }
};

Eigen::Vector3i cell_of(const Eigen::Vector3d& p, double cell) {
  return (p / cell).array().floor().cast<int>();
}

}  // namespace

SurfaceDistanceField::SurfaceDistanceField(const std::vector<Eigen::Vector3d>& surface, double cell,
                                           double cutoff)
    : cell_(cell), cutoff_(cutoff) {
  if (surface.empty() || !(cell > 0) || !(cutoff > 0)) return;
  // One representative per cell keeps the build linear in the surface area.
  std::unordered_set<Eigen::Vector3i, CellHash> seen;
  std::vector<Eigen::Vector3d> reps;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3d& p : surface) {
    if (!p.allFinite() || !seen.insert(cell_of(p, cell)).second) continue;
    reps.push_back(p);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  if (reps.empty()) return;
  const int reach = static_cast<int>(std::ceil(cutoff / cell));
  origin_ = lo - Eigen::Vector3d::Constant(reach * cell);
  size_ = (((hi - origin_) / cell).array().floor().cast<int>() + reach + 1).matrix();
  distance_.assign(static_cast<std::size_t>(size_.x()) * size_.y() * size_.z(),
                   static_cast<float>(cutoff));
  for (const Eigen::Vector3d& p : reps) {
    const Eigen::Vector3i c = ((p - origin_) / cell).array().round().cast<int>();
    for (int dz = -reach; dz <= reach; ++dz)
      for (int dy = -reach; dy <= reach; ++dy)
        for (int dx = -reach; dx <= reach; ++dx) {
          const Eigen::Vector3i q = c + Eigen::Vector3i(dx, dy, dz);
          const std::int64_t i = index(q);
          if (i < 0) continue;
          const double d = (origin_ + q.cast<double>() * cell - p).norm();
          float& slot = distance_[static_cast<std::size_t>(i)];
          slot = std::min(slot, static_cast<float>(std::min(d, cutoff)));
        }
  }
}

std::int64_t SurfaceDistanceField::index(const Eigen::Vector3i& c) const {
  if ((c.array() < 0).any() || (c.array() >= size_.array()).any()) return -1;
  return c.x() + static_cast<std::int64_t>(size_.x()) *
                     (c.y() + static_cast<std::int64_t>(size_.y()) * c.z());
}

double SurfaceDistanceField::distance(const Eigen::Vector3d& p) const {
  if (empty() || !p.allFinite()) return cutoff_;
  const std::int64_t i = index(((p - origin_) / cell_).array().round().cast<int>());
  return i < 0 ? cutoff_ : distance_[static_cast<std::size_t>(i)];
}

std::vector<TranslationCandidate> SurfaceDistanceField::search(
    const std::vector<Eigen::Vector3d>& points_camera, const Eigen::Matrix3d& R_world_camera,
    const Eigen::Vector3d& center, double radius, int count) const {
  std::vector<TranslationCandidate> out;
  if (empty() || points_camera.empty() || count <= 0 || !(radius >= 0) || !center.allFinite())
    return out;
  // Every point's grid cell at offset zero; an offset shifts all of them by whole cells.
  std::vector<Eigen::Vector3i> base;
  base.reserve(points_camera.size());
  for (const Eigen::Vector3d& p : points_camera)
    if (p.allFinite())
      base.push_back(((R_world_camera * p + center - origin_) / cell_).array().round().cast<int>());
  if (base.empty()) return out;
  const int n = static_cast<int>(std::floor(radius / cell_));
  const int side = 2 * n + 1;
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> cost(static_cast<std::size_t>(side) * side * side, inf);
  auto at = [&](int x, int y, int z) -> double& {
    return cost[static_cast<std::size_t>((x + n) + side * ((y + n) + side * (z + n)))];
  };
  const double cut2 = cutoff_ * cutoff_;
  // The offsets within the sphere, row by row: |x| <= reach[y, z] (-1: none in that row).
  std::vector<int> reach(static_cast<std::size_t>(side) * side, -1);
  for (int z = -n; z <= n; ++z)
    for (int y = -n; y <= n; ++y) {
      const int r2 = n * n - y * y - z * z;
      if (r2 < 0) continue;
      int r = static_cast<int>(std::sqrt(static_cast<double>(r2)));
      while (r * r > r2) --r;
      while ((r + 1) * (r + 1) <= r2) ++r;
      reach[static_cast<std::size_t>((y + n) + side * (z + n))] = r;
    }
  // Each offset's sum over the points in their order, one slab of offsets at a time (it stays in
  // the cache) and a row of the field at a time: the distances an offset row reads are
  // contiguous, and outside the grid every point counts the cutoff.
  std::vector<double> slab(static_cast<std::size_t>(side) * side);
  for (int z = -n; z <= n; ++z) {
    std::fill(slab.begin(), slab.end(), 0.0);
    for (const Eigen::Vector3i& b : base) {
      const int cz = b.z() + z;
      const bool z_inside = cz >= 0 && cz < size_.z();
      for (int y = -n; y <= n; ++y) {
        const int r = reach[static_cast<std::size_t>((y + n) + side * (z + n))];
        if (r < 0) continue;
        double* row = slab.data() + static_cast<std::ptrdiff_t>(side) * (y + n) + n;
        const int cy = b.y() + y;
        int lo = r + 1, hi = r;  // the offsets x in [lo, hi] read the field; none by default
        if (z_inside && cy >= 0 && cy < size_.y()) {
          lo = std::max(-r, -b.x());
          hi = std::min(r, size_.x() - 1 - b.x());
        }
        if (lo > hi) {
          for (int x = -r; x <= r; ++x) row[x] += cut2;
          continue;
        }
        for (int x = -r; x < lo; ++x) row[x] += cut2;
        const float* field = distance_.data() +
                             static_cast<std::ptrdiff_t>(size_.x()) *
                                 (cy + static_cast<std::ptrdiff_t>(size_.y()) * cz) +
                             b.x();
        for (int x = lo; x <= hi; ++x) {
          const double d = field[x];
          row[x] += d * d;
        }
        for (int x = hi + 1; x <= r; ++x) row[x] += cut2;
      }
    }
    for (int y = -n; y <= n; ++y) {
      const int r = reach[static_cast<std::size_t>((y + n) + side * (z + n))];
      for (int x = -r; x <= r; ++x)
        at(x, y, z) = slab[static_cast<std::size_t>((x + n) + side * (y + n))] /
                      static_cast<double>(base.size());
    }
  }
  // Local minima (no lower neighbour among the 26) that fit at least some points.
  struct Minimum {
    Eigen::Vector3i offset;
    double cost;
  };
  std::vector<Minimum> minima;
  for (int z = -n; z <= n; ++z)
    for (int y = -n; y <= n; ++y)
      for (int x = -n; x <= n; ++x) {
        const double c = at(x, y, z);
        if (!(c < cut2)) continue;
        bool lowest = true;
        for (int dz = -1; dz <= 1 && lowest; ++dz)
          for (int dy = -1; dy <= 1 && lowest; ++dy)
            for (int dx = -1; dx <= 1 && lowest; ++dx) {
              const int qx = x + dx, qy = y + dy, qz = z + dz;
              if (std::abs(qx) > n || std::abs(qy) > n || std::abs(qz) > n) continue;
              if (at(qx, qy, qz) < c) lowest = false;
            }
        if (lowest) minima.push_back({Eigen::Vector3i(x, y, z), c});
      }
  std::sort(minima.begin(), minima.end(),
            [](const Minimum& a, const Minimum& b) { return a.cost < b.cost; });
  std::vector<Eigen::Vector3i> taken;
  for (const Minimum& m : minima) {
    if (static_cast<int>(out.size()) >= count) break;
    // A plateau of equal minima counts once: keep candidates at least two cells apart.
    const bool distinct = std::none_of(taken.begin(), taken.end(), [&](const Eigen::Vector3i& t) {
      return (t - m.offset).cwiseAbs().maxCoeff() < 2;
    });
    if (!distinct) continue;
    taken.push_back(m.offset);
    TranslationCandidate c;
    c.translation = center + m.offset.cast<double>() * cell_;
    c.cost = m.cost;
    std::size_t near = 0;
    for (const Eigen::Vector3i& b : base) {
      const std::int64_t i = index(b + m.offset);
      if (i >= 0 && distance_[static_cast<std::size_t>(i)] <= cell_) ++near;
    }
    c.near_fraction = static_cast<double>(near) / static_cast<double>(base.size());
    out.push_back(c);
  }
  return out;
}

std::vector<TranslationCandidate> merge_candidates(const std::vector<TranslationCandidate>& a,
                                                   const std::vector<TranslationCandidate>& b,
                                                   int count, double separation) {
  std::vector<TranslationCandidate> all = a;
  all.insert(all.end(), b.begin(), b.end());
  std::stable_sort(
      all.begin(), all.end(),
      [](const TranslationCandidate& x, const TranslationCandidate& y) { return x.cost < y.cost; });
  return distinct_places(all, count, separation,
                         [](const TranslationCandidate& c) { return c.translation; });
}

std::vector<Eigen::Vector3d> spread_subset(const std::vector<Eigen::Vector3d>& points,
                                           std::size_t count) {
  if (points.size() <= count) return points;
  std::vector<Eigen::Vector3d> kept;
  const double stride = static_cast<double>(points.size()) / static_cast<double>(count);
  for (std::size_t i = 0; i < count; ++i)
    kept.push_back(points[static_cast<std::size_t>(static_cast<double>(i) * stride)]);
  return kept;
}

std::vector<Eigen::Vector3d> normal_space_subset(const std::vector<Eigen::Vector3d>& points,
                                                 const std::vector<Eigen::Vector3d>& normals,
                                                 std::size_t count) {
  if (normals.size() != points.size() || points.size() <= count)
    return spread_subset(points, count);
  // Bins of the sphere: each component of the normal rounded to a half (bins about 30 degrees
  // wide), in the order a bin first occurs.
  std::map<std::array<int, 3>, std::size_t> bin_of_key;
  std::vector<std::vector<std::size_t>> bins;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d& n = normals[i];
    const std::array<int, 3> key{static_cast<int>(std::lround(2 * n.x())),
                                 static_cast<int>(std::lround(2 * n.y())),
                                 static_cast<int>(std::lround(2 * n.z()))};
    const auto [it, added] = bin_of_key.try_emplace(key, bins.size());
    if (added) bins.emplace_back();
    bins[it->second].push_back(i);
  }
  // The largest share per bin that the count allows (water filling over the bins' sizes).
  std::vector<std::size_t> sizes;
  for (const auto& b : bins) sizes.push_back(b.size());
  std::sort(sizes.begin(), sizes.end());
  std::size_t share = 0, left = count, open = sizes.size();
  for (std::size_t s : sizes) {
    if ((s - share) * open > left) {
      share += left / open;
      left = 0;
      break;
    }
    left -= (s - share) * open;
    share = s;
    --open;
  }
  std::vector<std::vector<Eigen::Vector3d>> taken;
  std::size_t most = 0;
  for (const auto& b : bins) {
    std::vector<Eigen::Vector3d> in_bin;
    for (std::size_t i : b) in_bin.push_back(points[i]);
    taken.push_back(spread_subset(in_bin, std::min(share, b.size())));
    most = std::max(most, taken.back().size());
  }
  std::vector<Eigen::Vector3d> kept;
  for (std::size_t k = 0; k < most; ++k)
    for (const auto& t : taken)
      if (k < t.size()) kept.push_back(t[k]);
  return kept;
}

std::vector<Eigen::Vector3d> volume_surface_points(const HostVolume& volume) {
  std::vector<const VolumeBlock*> sorted;
  sorted.reserve(volume.blocks.size());
  for (const VolumeBlock& block : volume.blocks) sorted.push_back(&block);
  std::sort(sorted.begin(), sorted.end(), [](const VolumeBlock* a, const VolumeBlock* b) {
    return std::lexicographical_compare(a->coord.data(), a->coord.data() + 3, b->coord.data(),
                                        b->coord.data() + 3);
  });
  std::vector<Eigen::Vector3d> points;
  for (const VolumeBlock* b : sorted) {
    const VolumeBlock& block = *b;
    for (int k = 0; k < kBlockSide; ++k)
      for (int j = 0; j < kBlockSide; ++j)
        for (int i = 0; i < kBlockSide; ++i) {
          const Voxel& v = block.voxels[static_cast<std::size_t>(voxel_index(i, j, k))];
          if (v.weight > 0 && std::abs(v.tsdf) < 0.5f)
            points.push_back((block.coord * kBlockSide + Eigen::Vector3i(i, j, k)).cast<double>() *
                             static_cast<double>(volume.voxel_size));
        }
  }
  return points;
}

void SurfaceDistanceField::describe(StateArchive& archive) {
  archive(cell_, cutoff_, origin_, size_, distance_);
  const std::int64_t cells = std::int64_t{size_.x()} * size_.y() * size_.z();
  if (archive.reading() &&
      (size_.minCoeff() < 0 || cells != static_cast<std::int64_t>(distance_.size())))
    archive.fail("a distance field of " + std::to_string(distance_.size()) + " cells sized " +
                 std::to_string(cells));
}

}  // namespace imufusion

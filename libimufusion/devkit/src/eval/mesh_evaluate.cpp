// Mesh accuracy and completeness against an analytic scene (the measures of the Middlebury
// multi-view stereo benchmark, Seitz et al. 2006, in metric form).

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <string>
#include <thread>
#include <unordered_map>

#include "imufusion/mesh_eval.hpp"
#include "imufusion/synth.hpp"
#include "mesh/lattice_key.hpp"
#include "mesh/mesh_internal.hpp"

namespace imufusion {
namespace {

// Deterministic uniform numbers in [0, 1) (splitmix64): the same on every standard library.
class UniformSequence {
 public:
  explicit UniformSequence(std::uint64_t seed) : state_(seed) {}
  double next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * 0x1.0p-53;
  }

 private:
  std::uint64_t state_;
};

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3d closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                    const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  }
  const double denom = va + vb + vc;
  if (!(denom > 0)) return a;  // degenerate triangle: its points are all near a
  return a + ab * (vb / denom) + ac * (vc / denom);
}

// Triangles binned into a uniform grid of cubes of side `cell` (metres), for "is any triangle
// within `cell` of p" queries. Triangles spanning very many cells go to a list checked always.
class TriangleGrid {
 public:
  TriangleGrid(const Mesh& mesh, double cell) : mesh_(mesh), cell_(cell) {
    constexpr double kMaxCellsPerTriangle = 64;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> entries;
    entries.reserve(mesh.triangles.size() * 2);
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::max());
      Eigen::Vector3d hi = -lo;
      for (std::uint32_t v : mesh.triangles[t]) {
        lo = lo.cwiseMin(mesh.vertices[v].cast<double>());
        hi = hi.cwiseMax(mesh.vertices[v].cast<double>());
      }
      const Eigen::Vector3i a = cell_of(lo), b = cell_of(hi);
      const Eigen::Vector3i extent = b - a + Eigen::Vector3i::Ones();
      if (static_cast<double>(extent.x()) * extent.y() * extent.z() > kMaxCellsPerTriangle) {
        large_.push_back(static_cast<std::uint32_t>(t));
        continue;
      }
      for (int z = a.z(); z <= b.z(); ++z) {
        for (int y = a.y(); y <= b.y(); ++y) {
          for (int x = a.x(); x <= b.x(); ++x) {
            entries.emplace_back(mesh::pack20(Eigen::Vector3i(x, y, z)),
                                 static_cast<std::uint32_t>(t));
          }
        }
      }
    }
    std::sort(entries.begin(), entries.end());
    triangles_.resize(entries.size());
    for (std::size_t i = 0; i < entries.size(); ++i) {
      triangles_[i] = entries[i].second;
      auto [it, inserted] = ranges_.try_emplace(entries[i].first, i, i);
      it->second.second = i + 1;
    }
  }

  // Whether some triangle lies within `radius` (<= cell) of p.
  bool any_within(const Eigen::Vector3d& p, double radius) const {
    const double r2 = radius * radius;
    auto near = [&](std::uint32_t t) {
      const auto& tri = mesh_.triangles[t];
      const Eigen::Vector3d q = closest_on_triangle(p, mesh_.vertices[tri[0]].cast<double>(),
                                                    mesh_.vertices[tri[1]].cast<double>(),
                                                    mesh_.vertices[tri[2]].cast<double>());
      return (q - p).squaredNorm() <= r2;
    };
    const Eigen::Vector3i a = cell_of(p - Eigen::Vector3d::Constant(radius));
    const Eigen::Vector3i b = cell_of(p + Eigen::Vector3d::Constant(radius));
    for (int z = a.z(); z <= b.z(); ++z) {
      for (int y = a.y(); y <= b.y(); ++y) {
        for (int x = a.x(); x <= b.x(); ++x) {
          const auto it = ranges_.find(mesh::pack20(Eigen::Vector3i(x, y, z)));
          if (it == ranges_.end()) continue;
          for (std::size_t i = it->second.first; i < it->second.second; ++i) {
            if (near(triangles_[i])) return true;
          }
        }
      }
    }
    return std::any_of(large_.begin(), large_.end(), near);
  }

 private:
  // Clamped so that far-off (but finite) points convert safely; such cells are empty anyway.
  Eigen::Vector3i cell_of(const Eigen::Vector3d& p) const {
    constexpr double kLimit = 1 << 28;
    return (p / cell_).array().floor().cwiseMax(-kLimit).cwiseMin(kLimit).cast<int>();
  }

  const Mesh& mesh_;
  double cell_;
  std::vector<std::uint32_t> triangles_;  // sorted by cell
  std::unordered_map<std::uint64_t, std::pair<std::size_t, std::size_t>> ranges_;
  std::vector<std::uint32_t> large_;
};

// Runs work(begin, end) over [0, n) split into one contiguous chunk per hardware thread.
void parallel_chunks(std::size_t n, const std::function<void(std::size_t, std::size_t)>& work) {
  const std::size_t threads = std::clamp<std::size_t>(std::thread::hardware_concurrency(), 1,
                                                      std::max<std::size_t>(1, n / 4096));
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) {
    pool.emplace_back(work, n * t / threads, n * (t + 1) / threads);
  }
  work(0, n / threads);
  for (auto& thread : pool) thread.join();
}

double quantile(std::vector<double>& values, double q) {
  const auto k = static_cast<std::size_t>(std::floor(q * static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

Result<MeshAccuracy> evaluate_mesh(const Mesh& mesh, const synth::Scene& scene,
                                   const std::vector<Eigen::Vector3d>& reference_points,
                                   const MeshEvalOptions& options) {
  IMUFUSION_RETURN_IF_ERROR(mesh::check_mesh_for(mesh, "evaluate_mesh"));
  if (reference_points.empty()) {
    return make_error(ErrorCode::kInvalidArgument, "evaluate_mesh: no reference points");
  }
  if (!(options.completeness_threshold > 0.0) || !(options.sample_spacing > 0.0) ||
      options.max_samples == 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      "evaluate_mesh: threshold " + std::to_string(options.completeness_threshold) +
                          " m, spacing " + std::to_string(options.sample_spacing) +
                          " m and max_samples must be positive");
  }
  MeshAccuracy result;
  result.completeness_threshold = options.completeness_threshold;
  result.reference_points = reference_points.size();

  // Accuracy: area-uniform samples of the mesh, stratified along the cumulative area so every
  // triangle gets its share.
  std::vector<double> cumulative(mesh.triangles.size());
  double area = 0.0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[tri[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[tri[2]].cast<double>();
    area += 0.5 * (b - a).cross(c - a).norm();
    cumulative[t] = area;
  }
  if (area > 0.0) {
    const double wanted = std::ceil(area / (options.sample_spacing * options.sample_spacing));
    const std::size_t n = std::max<std::size_t>(
        1, std::min<std::size_t>(options.max_samples, static_cast<std::size_t>(wanted)));
    std::vector<double> distances(n);
    parallel_chunks(n, [&](std::size_t begin, std::size_t end) {
      std::size_t t = 0;
      for (std::size_t k = begin; k < end; ++k) {
        // Each sample draws from its own stream, so the result does not depend on the chunks.
        UniformSequence uniform(options.seed * 0x9E3779B97F4A7C15ull + k);
        const double target =
            (static_cast<double>(k) + uniform.next()) / static_cast<double>(n) * area;
        if (k == begin) {
          t = static_cast<std::size_t>(
              std::upper_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin());
        }
        while (t + 1 < cumulative.size() && cumulative[t] <= target) ++t;
        t = std::min(t, cumulative.size() - 1);
        const auto& tri = mesh.triangles[t];
        // Uniform point in the triangle (Osada et al. 2002).
        const double r1 = std::sqrt(uniform.next()), r2 = uniform.next();
        const Eigen::Vector3d p = (1.0 - r1) * mesh.vertices[tri[0]].cast<double>() +
                                  r1 * (1.0 - r2) * mesh.vertices[tri[1]].cast<double>() +
                                  r1 * r2 * mesh.vertices[tri[2]].cast<double>();
        distances[k] = synth::distance_to_surface(scene, p);
      }
    });
    result.mesh_samples = distances.size();
    result.accuracy_mean =
        std::accumulate(distances.begin(), distances.end(), 0.0) / static_cast<double>(n);
    result.accuracy_median = quantile(distances, 0.5);
    result.accuracy_p90 = quantile(distances, 0.9);
  } else {
    result.accuracy_mean = result.accuracy_median = result.accuracy_p90 =
        std::numeric_limits<double>::quiet_NaN();
  }

  // Completeness: exact point-to-triangle distances against the triangles near each point.
  const TriangleGrid grid(mesh, options.completeness_threshold);
  std::vector<std::uint8_t> near(reference_points.size(), 0);
  parallel_chunks(reference_points.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      near[i] = grid.any_within(reference_points[i], options.completeness_threshold) ? 1 : 0;
    }
  });
  const auto covered = static_cast<std::size_t>(std::count(near.begin(), near.end(), 1));
  result.completeness = static_cast<double>(covered) / static_cast<double>(reference_points.size());
  return result;
}

}  // namespace imufusion

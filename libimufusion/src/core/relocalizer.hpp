#pragma once
// Relocalization after a long loss: where is the camera, given the model, the frame's points and
// an orientation the gyroscope still knows well?
//
// Dead reckoning keeps the rotation within a degree or two over seconds, but the translation
// drifts by decimetres (an uncorrectable tilt error turns gravity into a false acceleration), far
// beyond ICP's basin. So the search is over translation only: a distance field of the model's
// surface on a coarse grid, and for every grid offset within a radius of the dead-reckoned
// position the robust chamfer cost of the frame's points (mean of min(d, cutoff)^2). The lowest
// local minima are the candidates; the caller runs full ICP from each and accepts only an
// alignment that is reliable in all six directions. Pure C++, no GPU.

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/state_archive.hpp"
#include "imufusion/volume.hpp"

namespace imufusion {

struct TranslationCandidate {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  // world, metres
  double cost = 0;           // mean of min(d, cutoff)^2 over the points, m^2
  double near_fraction = 0;  // points whose distance is within one cell
};

/// Unsigned distance to the nearest surface point, sampled at the centres of a regular grid that
/// covers the surface and `cutoff` around it; min(distance, cutoff) everywhere.
class SurfaceDistanceField {
 public:
  SurfaceDistanceField() = default;
  /// `surface`: world points on the surface (any density; one per cell is kept).
  SurfaceDistanceField(const std::vector<Eigen::Vector3d>& surface, double cell, double cutoff);

  bool empty() const { return distance_.empty(); }
  double cell() const { return cell_; }
  double cutoff() const { return cutoff_; }
  /// Distance at the nearest grid centre; cutoff outside the grid.
  double distance(const Eigen::Vector3d& p) const;
  void describe(StateArchive& archive);  // the changing state, for a saved scan

  /// The `count` best translations t (lowest cost first, distinct local minima of the cost over
  /// grid offsets of one cell) such that R * p + t fits the surface, searched over the cells
  /// within `radius` of `center`. `points_camera`: the frame's points in its camera frame.
  std::vector<TranslationCandidate> search(const std::vector<Eigen::Vector3d>& points_camera,
                                           const Eigen::Matrix3d& R_world_camera,
                                           const Eigen::Vector3d& center, double radius,
                                           int count) const;

 private:
  std::int64_t index(const Eigen::Vector3i& c) const;
  double cell_ = 0.05, cutoff_ = 0.25;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();  // centre of cell (0, 0, 0)
  Eigen::Vector3i size_ = Eigen::Vector3i::Zero();
  std::vector<float> distance_;
};

/// The `count` lowest-cost candidates of two searches (regions that may overlap), one of a pair
/// closer than `separation` along every axis counting once (the lower cost kept): the rule
/// SurfaceDistanceField::search applies within one search, with separation = 2 cells.
std::vector<TranslationCandidate> merge_candidates(const std::vector<TranslationCandidate>& a,
                                                   const std::vector<TranslationCandidate>& b,
                                                   int count, double separation);

/// The items of `sorted` (lowest cost first) in order, each kept unless a kept one lies closer
/// than `separation` along every axis, until `count` are kept; `place(item)` is its translation.
template <class T, class Place>
std::vector<T> distinct_places(const std::vector<T>& sorted, int count, double separation,
                               Place place) {
  std::vector<T> out;
  for (const T& item : sorted) {
    if (static_cast<int>(out.size()) >= count) break;
    if (std::none_of(out.begin(), out.end(), [&](const T& kept) {
          return (place(kept) - place(item)).cwiseAbs().maxCoeff() < separation;
        }))
      out.push_back(item);
  }
  return out;
}

/// At most `count` of `points`, spread evenly over their order; all of them when fewer.
std::vector<Eigen::Vector3d> spread_subset(const std::vector<Eigen::Vector3d>& points,
                                           std::size_t count);

/// At most `count` of `points`, spread over the directions of their unit `normals` (one per
/// point; a zero normal is a direction of its own): each direction's bin of the sphere keeps the
/// same share, all of its points when it has fewer, each bin's spread evenly over their order
/// (normal-space sampling, Rusinkiewicz and Levoy 2001), the bins taken in turn. Without normals
/// (`normals` of another size), spread_subset.
std::vector<Eigen::Vector3d> normal_space_subset(const std::vector<Eigen::Vector3d>& points,
                                                 const std::vector<Eigen::Vector3d>& normals,
                                                 std::size_t count);

/// World points of the zero crossing of a TSDF snapshot: the voxels observed (weight > 0) with
/// |tsdf| below half the truncation band, one point per voxel, in the order of the blocks'
/// coordinates: the same for the same model whatever order the GPU allocated its blocks in.
std::vector<Eigen::Vector3d> volume_surface_points(const HostVolume& volume);

}  // namespace imufusion

#pragma once
// Accuracy and completeness of a mesh against a synthetic scene's true surface (imufusion-fuse,
// imufusion-mesh-eval, tests and benches). World frame, metres.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "imufusion/mesh.hpp"
#include "imufusion/result.hpp"
#include "imufusion/synth.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

/// Which ground-truth surface points count as seen: the sensor's range and incidence limits.
struct SurfaceSampleOptions {
  int frame_step = 1;                       // use every n-th pose
  int pixel_step = 8;                       // cast a ray through every n-th pixel on both axes
  double min_depth = 0.4, max_depth = 4.5;  // metres along the optical axis
  double max_incidence_deg = 78.0;          // angle between ray and surface normal
  double cell_size = 0.01;  // metres: keep one point per cell, so the points are spread evenly
};

/// Points of the true surface seen from the given camera poses (T_world_camera), world frame,
/// metres: exact ray casts through a pixel grid, thinned to one point per cell. Empty when an
/// option or the focal length is not positive.
std::vector<Eigen::Vector3d> observed_surface_points(const synth::Scene& scene,
                                                     const Trajectory& poses,
                                                     const Intrinsics& intrinsics,
                                                     const SurfaceSampleOptions& options = {});

struct MeshEvalOptions {
  double completeness_threshold = 0.02;  // metres
  double sample_spacing = 0.005;         // metres: one accuracy sample per spacing^2 of mesh area
  std::size_t max_samples = 4'000'000;   // cap on accuracy samples (spacing grows beyond it)
  std::uint64_t seed = 1;                // triangle sampling
};

/// Accuracy (mesh -> truth) and completeness (truth -> mesh) of a mesh against a synthetic scene.
struct MeshAccuracy {
  // Distance from area-uniform samples of the mesh surface to the nearest true surface, metres.
  // NaN when the mesh has no area.
  double accuracy_mean = 0.0, accuracy_median = 0.0, accuracy_p90 = 0.0;
  // Fraction of reference points closer than the threshold to the mesh surface.
  double completeness = 0.0;
  double completeness_threshold = 0.0;  // metres
  std::size_t mesh_samples = 0, reference_points = 0;
};

/// `reference_points`: true-surface samples (e.g. observed_surface_points()). Distances to the
/// mesh are exact point-triangle distances (a uniform grid of triangles finds the candidates).
/// kInvalidArgument when the mesh is malformed, no reference points are given or an option is
/// out of range.
Result<MeshAccuracy> evaluate_mesh(const Mesh& mesh, const synth::Scene& scene,
                                   const std::vector<Eigen::Vector3d>& reference_points,
                                   const MeshEvalOptions& options = {});

}  // namespace imufusion

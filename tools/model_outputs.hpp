#pragma once
// What imufusion-scan and imufusion-fuse share: fusion at known poses (a TUM trajectory, e.g.
// ground truth or external tracking) and the outputs of the fused model, written into the
// staging directory of an output set (io/output_set.hpp): mesh.glb, mesh.ply, preview.png (the
// model from the last pose) and overview.png (from outside the whole volume).

#include <optional>
#include <string>
#include <utility>

#include "imufusion/image_io.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/trajectory.hpp"
#include "io/output_set.hpp"
#include "overview_pose.hpp"

namespace imufusion::tools {

/// The files write_model_outputs() writes.
inline constexpr const char* kModelOutputs[] = {"mesh.glb", "mesh.ply", "preview.png",
                                                "overview.png"};

/// Fuses `frame` at its pose in `known` (the nearest within 20 ms, find_pose); nullopt when
/// `known` has no pose for it.
inline Result<std::optional<FrameResult>> fuse_at_known_pose(Reconstructor& rec,
                                                             const Trajectory& known,
                                                             const Frame& frame) {
  const StampedPose* pose = find_pose(known, frame.timestamp);
  if (pose == nullptr) return std::optional<FrameResult>{};
  auto result =
      rec.fuse_with_pose(frame.timestamp, frame.depth, frame.color ? &*frame.color : nullptr,
                         pose->T_world_camera, frame.imu);
  if (!result) return result.error();
  return std::optional<FrameResult>(std::move(*result));
}

/// Writes `mesh` (the model's, with triangles) as mesh.glb and mesh.ply, and the model seen from
/// the last pose of the trajectory (preview.png) and from outside the volume (overview.png).
inline Status write_model_outputs(const io::OutputSet& set, Reconstructor& rec, const Mesh& mesh) {
  IMUFUSION_RETURN_IF_ERROR(write_glb(set.staged("mesh.glb"), mesh));
  IMUFUSION_RETURN_IF_ERROR(write_ply(set.staged("mesh.ply"), mesh));
  auto preview = rec.raycast(rec.trajectory().back().T_world_camera);
  if (!preview) return preview.error();
  IMUFUSION_RETURN_IF_ERROR(write_color_png(set.staged("preview.png"), preview->shaded));
  auto volume = rec.snapshot();
  if (!volume) return volume.error();
  auto overview = rec.raycast(
      overview_pose(*volume, rec.trajectory().front().T_world_camera, rec.config().intrinsics),
      std::nullopt, std::pair{0.1f, 100.0f});
  if (!overview) return overview.error();
  return write_color_png(set.staged("overview.png"), overview->shaded);
}

}  // namespace imufusion::tools

#pragma once
// The preprocessing kernels' dispatcher: owns their pipelines and the per-level GPU buffers,
// which later stages (ICP, fusion) bind directly.

#include <memory>
#include <vector>

#include "imufusion/preprocess.hpp"
#include "imufusion_layouts.h"
#include "vk/buffer.hpp"
#include "vk/command_sequence.hpp"
#include "vk/context.hpp"
#include "vk/pipeline.hpp"

namespace imufusion::gpu {

class Preprocessor {
 public:
  static Result<Preprocessor> create(std::shared_ptr<Context> context,
                                     const PreprocessConfig& config, const Intrinsics& intrinsics);

  /// Uploads `depth` into the raw buffer, row by row (sizes are checked); float metres go to
  /// the level-0 metres buffer and record() then skips depth_to_metres.
  Status upload(const DepthView& depth);
  /// Uploads ready-made level-0 vertex and normal maps (e.g. a model raycast) instead of a depth
  /// image; the coarser levels are built on the GPU as by record_maps_from(), in one submission
  /// of `seq` (at least maps_dispatch_count() dispatches). The depth buffers are left as they were.
  Status upload_maps(CommandSequence& seq, const Vec4Image& vertices, const Vec4Image& normals);
  /// Records the copy of full-resolution maps already on the GPU (a model raycast, float4 per
  /// pixel) into level 0 and the coarser levels built from them on the GPU
  /// (shaders/map_pyramid_down.comp, host reference in reference/map_pyramid.hpp): no host round
  /// trip. The depth buffers are left as they were.
  /// `first_level`: the maps are of that level's size and fill it and the coarser ones.
  void record_maps_from(CommandSequence& seq, const Buffer& vertices, const Buffer& normals,
                        int first_level = 0) const;
  /// Number of dispatches record_maps_from() adds.
  std::uint32_t maps_dispatch_count() const;
  /// Records every preprocessing dispatch into `seq` (between begin and submit); vertex and
  /// normal maps from `first_map_level` on (the levels ICP uses), depth at every level, the
  /// bilateral filter at `first_map_level` (PreprocessConfig's radius and sigma scaled to it).
  void record(CommandSequence& seq, int first_map_level = 0) const;
  /// Number of dispatches record() adds.
  std::uint32_t dispatch_count() const;
  /// The one preprocessing path: upload(), then record() into `seq` and submit it without
  /// waiting (seq.wait() returns the kernels' timings; later submissions see the results).
  Status submit(CommandSequence& seq, const DepthView& depth, int first_map_level = 0);
  /// Copies the results of the last submitted run to the host.
  Result<PreprocessedFrame> download() const;

  const Buffer& raw_depth_metres() const { return raw_metres_; }
  const Buffer& depth(int level) const { return depth_[static_cast<std::size_t>(level)]; }
  const Buffer& vertices(int level) const { return vertices_[static_cast<std::size_t>(level)]; }
  const Buffer& normals(int level) const { return normals_[static_cast<std::size_t>(level)]; }
  const Intrinsics& intrinsics(int level) const { return levels_[static_cast<std::size_t>(level)]; }
  const PreprocessConfig& config() const { return config_; }
  /// Where each level-0 pixel is taken from in a distorted frame (undistortion_sources): the
  /// colour registered to the frame is resampled the same way. Empty for a pinhole camera.
  const std::vector<std::int32_t>& undistortion() const { return sources_; }

 private:
  /// The 2x2 reduction from `level - 1` to `level` (depth and map pyramids alike).
  layout::PyramidDownParams pyramid_down(int level) const;
  /// Records the map pyramid's levels below `first_level`, built from it on the GPU.
  void record_map_pyramid(CommandSequence& seq, int first_level) const;
  Status upload_metres(const DepthView& depth);

  PreprocessConfig config_;
  std::vector<Intrinsics> levels_;
  ComputePipeline to_metres_, bilateral_, pyramid_down_, vertex_map_, normal_map_, map_pyramid_;
  Buffer raw_;         // uint16 pairs
  Buffer raw_metres_;  // level 0, unfiltered
  std::vector<Buffer> depth_, vertices_, normals_;
  Buffer filter_input_;  // the unfiltered depth of a filter level below 0 (level 1's size)
  double depth_scale_ = 0;
  bool metres_input_ = false;          // the last upload was float metres
  std::vector<float> metres_scratch_;  // float metres when raw_metres_ is not host-visible
  // Per pixel of level 0, its source pixel in a distorted frame (undistortion_sources); empty for
  // a pinhole camera.
  std::vector<std::int32_t> sources_;
};

}  // namespace imufusion::gpu

// TsdfFusion: the public face of the GPU volume (preprocessing for metric depth, allocation,
// integration, raycast, snapshot).

#include "imufusion/fusion.hpp"

#include <utility>

#include "gpu/preprocessor.hpp"
#include "gpu/rgba.hpp"
#include "gpu/volume.hpp"

namespace imufusion {
struct TsdfFusion::Impl {
  std::shared_ptr<gpu::Context> context;
  Intrinsics intrinsics;
  PreprocessConfig preprocess_config;
  gpu::Preprocessor preprocess;
  gpu::CommandSequence preprocess_seq;
  gpu::TsdfVolume volume;
  gpu::Buffer color;
  std::vector<std::uint32_t> rgba;
};

TsdfFusion::TsdfFusion(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
TsdfFusion::~TsdfFusion() = default;
TsdfFusion::TsdfFusion(TsdfFusion&&) noexcept = default;
TsdfFusion& TsdfFusion::operator=(TsdfFusion&&) noexcept = default;

Result<TsdfFusion> TsdfFusion::create(const VolumeConfig& volume,
                                      const PreprocessConfig& preprocess,
                                      const Intrinsics& intrinsics, const DeviceOptions& device) {
  auto context = gpu::Context::create(device);
  if (!context) return context.error();
  auto impl = std::make_unique<Impl>();
  impl->context = *context;
  impl->intrinsics = intrinsics;
  impl->preprocess_config = preprocess;
  auto pre = gpu::Preprocessor::create(impl->context, preprocess, intrinsics);
  if (!pre) return pre.error();
  impl->preprocess = std::move(*pre);
  auto seq = gpu::CommandSequence::create(
      impl->context, impl->preprocess.dispatch_count() + gpu::TsdfVolume::kIntegrateDispatches);
  if (!seq) return seq.error();
  impl->preprocess_seq = std::move(*seq);
  auto vol = gpu::TsdfVolume::create(impl->context, volume, preprocess.workgroup_x,
                                     preprocess.workgroup_y);
  if (!vol) return vol.error();
  impl->volume = std::move(*vol);
  auto color = gpu::Buffer::create(  // host-visible: read once per frame
      impl->context, static_cast<std::size_t>(intrinsics.width) * intrinsics.height * 4, true);
  if (!color) return color.error();
  impl->color = std::move(*color);
  return TsdfFusion(std::move(impl));
}

Result<IntegrationStats> TsdfFusion::integrate(const DepthImage& depth, const ColorImage* color,
                                               const Eigen::Isometry3d& T_world_camera,
                                               std::vector<KernelTiming>* timings) {
  Impl& m = *impl_;
  if (color != nullptr && (color->width != depth.width || color->height != depth.height)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "colour image " + std::to_string(color->width) + "x" +
                          std::to_string(color->height) + " does not match depth " +
                          std::to_string(depth.width) + "x" + std::to_string(depth.height));
  }
  IMUFUSION_RETURN_IF_ERROR(m.preprocess.upload(depth));
  if (color != nullptr) IMUFUSION_RETURN_IF_ERROR(gpu::upload_rgba(*color, m.color, m.rgba));
  // Preprocessing and integration in one submission.
  IMUFUSION_RETURN_IF_ERROR(m.preprocess_seq.begin());
  m.preprocess.record(m.preprocess_seq);
  const Status recorded = m.volume.record_integrate(
      m.preprocess_seq, m.preprocess.raw_depth_metres(), color != nullptr ? &m.color : nullptr,
      m.intrinsics, T_world_camera);
  auto t = m.preprocess_seq.submit_and_wait();  // ends the recording also after a failed record
  IMUFUSION_RETURN_IF_ERROR(recorded);
  if (!t) return t.error();
  if (timings != nullptr) timings->insert(timings->end(), t->begin(), t->end());
  return m.volume.finish_integrate();
}

Result<RaycastImages> TsdfFusion::raycast(const Eigen::Isometry3d& T_world_camera,
                                          std::optional<Intrinsics> intrinsics,
                                          std::vector<KernelTiming>* timings,
                                          std::optional<std::pair<float, float>> depth_range) {
  const Intrinsics k = intrinsics.value_or(impl_->intrinsics);
  const auto [near_depth, far_depth] = depth_range.value_or(
      std::pair{impl_->preprocess_config.min_depth, impl_->preprocess_config.max_depth});
  if (!(near_depth >= 0 && far_depth > near_depth))
    return make_error(ErrorCode::kInvalidArgument, "raycast depth range is empty");
  const auto pixels = static_cast<std::size_t>(k.width) * k.height;
  if (pixels == 0) return make_error(ErrorCode::kInvalidArgument, "raycast of an empty image");
  std::vector<gpu::Buffer> buffers;
  for (std::size_t bytes : {pixels * 16, pixels * 16, pixels * 4, pixels * 4}) {
    auto b = gpu::Buffer::create(impl_->context, bytes);
    if (!b) return b.error();
    buffers.push_back(std::move(*b));
  }
  IMUFUSION_RETURN_IF_ERROR(impl_->volume.raycast(k, T_world_camera, near_depth, far_depth,
                                                  buffers[0], buffers[1], buffers[2], buffers[3],
                                                  timings));
  RaycastImages out;
  for (int i = 0; i < 2; ++i) {
    Vec4Image& image = i == 0 ? out.vertices : out.normals;
    image.width = k.width;
    image.height = k.height;
    image.data.resize(pixels);
    IMUFUSION_RETURN_IF_ERROR(
        buffers[static_cast<std::size_t>(i)].download(image.data.data(), pixels * 16));
  }
  auto shaded = buffers[2].download_as<std::uint32_t>(pixels);
  if (!shaded) return shaded.error();
  auto colors = buffers[3].download_as<std::uint32_t>(pixels);
  if (!colors) return colors.error();
  out.shaded = gpu::unpack_rgba(*shaded, k.width, k.height);
  out.color = gpu::unpack_rgba(*colors, k.width, k.height);
  return out;
}

Result<std::vector<std::uint32_t>> TsdfFusion::last_raycast_steps() const {
  return impl_->volume.last_raycast_steps();
}
Result<HostVolume> TsdfFusion::snapshot() const { return impl_->volume.snapshot(); }
Status TsdfFusion::reset() { return impl_->volume.reset(); }
const DeviceInfo& TsdfFusion::device() const { return impl_->context->info(); }
std::uint32_t TsdfFusion::allocated_blocks() const { return impl_->volume.allocated_blocks(); }
std::uint64_t TsdfFusion::memory_bytes() const { return impl_->volume.config().reserved_bytes(); }
std::uint32_t TsdfFusion::validation_error_count() const {
  return impl_->context->validation_error_count();
}

}  // namespace imufusion

// IcpTracker: the public GPU ICP between two depth frames (preprocessing + association +
// reduction on the device, Gauss-Newton on the host).

#include <array>
#include <utility>

#include "gpu/icp_kernels.hpp"
#include "gpu/preprocessor.hpp"
#include "imufusion/icp.hpp"
#include "vk/command_sequence.hpp"
#include "vk/context.hpp"

namespace imufusion {

struct IcpTracker::Impl {
  std::shared_ptr<gpu::Context> context;
  IcpConfig icp;
  std::array<gpu::Preprocessor, 2> frames;  // the reference and the current frame, ping-pong
  int reference = 0;
  bool has_reference = false;
  gpu::IcpKernels kernels;
  gpu::CommandSequence preprocess_seq;
  gpu::CommandSequence icp_seq;

  Status preprocess(int slot, const DepthImage& depth, std::vector<KernelTiming>* timings) {
    gpu::Preprocessor& frame = frames[static_cast<std::size_t>(slot)];
    IMUFUSION_RETURN_IF_ERROR(frame.submit(preprocess_seq, depth));
    auto t = preprocess_seq.wait();
    if (!t) return t.error();
    if (timings != nullptr) timings->insert(timings->end(), t->begin(), t->end());
    return {};
  }
};

IcpTracker::IcpTracker(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
IcpTracker::~IcpTracker() = default;
IcpTracker::IcpTracker(IcpTracker&&) noexcept = default;
IcpTracker& IcpTracker::operator=(IcpTracker&&) noexcept = default;

Result<IcpTracker> IcpTracker::create(const IcpConfig& icp, const PreprocessConfig& preprocess,
                                      const Intrinsics& intrinsics, const DeviceOptions& device) {
  IMUFUSION_RETURN_IF_ERROR(preprocess.validate());
  IMUFUSION_RETURN_IF_ERROR(icp.validate(preprocess.levels));
  auto context = gpu::Context::create(device);
  if (!context) return context.error();
  auto impl = std::make_unique<Impl>();
  impl->context = *context;
  impl->icp = icp;
  for (auto& frame : impl->frames) {
    auto kernels = gpu::Preprocessor::create(impl->context, preprocess, intrinsics);
    if (!kernels) return kernels.error();
    frame = std::move(*kernels);
  }
  auto kernels = gpu::IcpKernels::create(
      impl->context, static_cast<std::size_t>(intrinsics.width) * intrinsics.height,
      preprocess.workgroup_x, preprocess.workgroup_y, icp.depth_noise, icp.normal_gate);
  if (!kernels) return kernels.error();
  impl->kernels = std::move(*kernels);
  auto pre_seq = gpu::CommandSequence::create(impl->context, impl->frames[0].dispatch_count());
  if (!pre_seq) return pre_seq.error();
  impl->preprocess_seq = std::move(*pre_seq);
  auto icp_seq = gpu::CommandSequence::create(impl->context, gpu::IcpKernels::kDispatches);
  if (!icp_seq) return icp_seq.error();
  impl->icp_seq = std::move(*icp_seq);
  return IcpTracker(std::move(impl));
}

Status IcpTracker::set_reference(const DepthImage& depth) {
  IMUFUSION_RETURN_IF_ERROR(impl_->preprocess(impl_->reference, depth, nullptr));
  impl_->has_reference = true;
  return {};
}

Status IcpTracker::set_reference_maps(const Vec4Image& vertices, const Vec4Image& normals) {
  IMUFUSION_RETURN_IF_ERROR(impl_->frames[static_cast<std::size_t>(impl_->reference)].upload_maps(
      impl_->preprocess_seq, vertices, normals));
  impl_->has_reference = true;
  return {};
}

Result<IcpResult> IcpTracker::track(const DepthImage& depth,
                                    const Eigen::Isometry3d& T_ref_cur_init,
                                    std::vector<KernelTiming>* timings) {
  if (!impl_->has_reference)
    return make_error(ErrorCode::kInvalidArgument, "IcpTracker::track before set_reference");
  const int current = 1 - impl_->reference;
  IMUFUSION_RETURN_IF_ERROR(impl_->preprocess(current, depth, timings));
  gpu::GpuNormalEquationSource source(
      impl_->kernels, impl_->icp_seq, impl_->frames[static_cast<std::size_t>(current)],
      impl_->frames[static_cast<std::size_t>(impl_->reference)], timings);
  return run_icp(source, impl_->icp, T_ref_cur_init);
}

const DeviceInfo& IcpTracker::device() const { return impl_->context->info(); }

std::uint32_t IcpTracker::validation_error_count() const {
  return impl_->context->validation_error_count();
}

}  // namespace imufusion

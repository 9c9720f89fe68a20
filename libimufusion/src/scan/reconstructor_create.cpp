// Reconstructor's construction: the GPU context, the per-stage dispatchers and buffers, the
// inertial navigator, and the tracking resolution chosen for the device.

#include <algorithm>
#include <memory>
#include <utility>

#include "scan/reconstructor_impl.hpp"

namespace imufusion {

Reconstructor::Reconstructor(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Reconstructor::~Reconstructor() = default;
Reconstructor::Reconstructor(Reconstructor&&) noexcept = default;
Reconstructor& Reconstructor::operator=(Reconstructor&&) noexcept = default;

namespace {

// ReconstructorConfig::tracking_level -1: on a CPU device the coarsest level of at least
// 320x240 (half of a 640x480 frame), on a GPU the full frame.
int resolve_tracking_level(const ReconstructorConfig& config, DeviceType device) {
  if (config.tracking_level >= 0) return config.tracking_level;
  if (device != DeviceType::kCpu) return 0;
  int level = 0;
  while (level + 1 < config.preprocess.levels &&
         config.intrinsics.at_level(level + 1).width >= kMinCpuTrackingWidth &&
         config.intrinsics.at_level(level + 1).height >= kMinCpuTrackingHeight)
    ++level;
  return level;
}

// ReconstructorConfig::reference_frames 0: kCpuReferenceFrames on a CPU device, 1 on a GPU.
int resolve_reference_frames(const ReconstructorConfig& config, DeviceType device) {
  if (config.reference_frames > 0) return config.reference_frames;
  return device == DeviceType::kCpu ? kCpuReferenceFrames : 1;
}

}  // namespace

Result<Reconstructor> Reconstructor::create(const ReconstructorConfig& config) {
  IMUFUSION_RETURN_IF_ERROR(config.validate());
  auto context = gpu::Context::create(config.device);
  if (!context) return context.error();
  auto impl = std::make_unique<Impl>();
  Impl& m = *impl;
  m.config = config;
  m.context = *context;
  m.machine = TrackingStateMachine(config.tracking);
  m.pairing = PairingReference(config.tracking);
  m.prediction_calibration = PredictionCalibration(config.tracking);
  m.relocalization = RelocalizationDriver(config);
  m.recovery = LossRecovery(config);
  m.tracking_level = resolve_tracking_level(config, m.context->info().type);
  m.reference_frames = resolve_reference_frames(config, m.context->info().type);
  const Intrinsics& k = config.intrinsics;
  const auto pixels = static_cast<std::size_t>(k.width) * k.height;
  for (gpu::Preprocessor* p : {&m.current, &m.reference}) {
    auto created = gpu::Preprocessor::create(m.context, config.preprocess, k);
    if (!created) return created.error();
    *p = std::move(*created);
  }
  auto pre_seq = gpu::CommandSequence::create(m.context, m.current.dispatch_count());
  if (!pre_seq) return pre_seq.error();
  m.preprocess_seq = std::move(*pre_seq);
  auto fuse_seq = gpu::CommandSequence::create(m.context, gpu::TsdfVolume::kIntegrateDispatches +
                                                              gpu::TsdfVolume::kRaycastDispatches +
                                                              m.reference.maps_dispatch_count());
  if (!fuse_seq) return fuse_seq.error();
  m.fuse_seq = std::move(*fuse_seq);
  auto icp_seq = gpu::CommandSequence::create(m.context, gpu::IcpKernels::kPhotometricDispatches);
  if (!icp_seq) return icp_seq.error();
  m.icp_seq = std::move(*icp_seq);
  auto kernels = gpu::IcpKernels::create(m.context, pixels, config.preprocess.workgroup_x,
                                         config.preprocess.workgroup_y, config.icp.depth_noise,
                                         config.icp.normal_gate);
  if (!kernels) return kernels.error();
  m.icp_kernels = std::move(*kernels);
  auto volume = gpu::TsdfVolume::create(m.context, config.volume, config.preprocess.workgroup_x,
                                        config.preprocess.workgroup_y);
  if (!volume) return volume.error();
  m.volume = std::move(*volume);
  auto color = gpu::Buffer::create(m.context, pixels * 4, true);  // read once per fused frame
  if (!color) return color.error();
  m.color = std::move(*color);
  auto model = RaycastBuffers::create(m.context, pixels);
  if (!model) return model.error();
  m.model = std::move(*model);
  if (config.imu.enabled) {
    auto navigator = InertialNavigator::create(config.inertial);
    if (!navigator) return navigator.error();
    m.navigator.emplace(std::move(*navigator));
  }
  return Reconstructor(std::move(impl));
}

}  // namespace imufusion

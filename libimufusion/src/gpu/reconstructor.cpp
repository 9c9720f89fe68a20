// Reconstructor: one Vulkan context shared by preprocessing, ICP, fusion and raycast; the host
// runs Gauss-Newton, the IMU estimators and the tracking state machine.

#include <chrono>
#include <cstdio>
#include <cmath>
#include <string>
#include <utility>

#include "gpu/command_sequence.hpp"
#include "gpu/context.hpp"
#include "gpu/icp_kernels.hpp"
#include "gpu/preprocessor.hpp"
#include "gpu/rgba.hpp"
#include "gpu/volume.hpp"
#include "imufusion/reconstructor.hpp"

namespace imufusion {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

struct RaycastBuffers {
  gpu::Buffer vertices, normals, shaded, colors;

  static Result<RaycastBuffers> create(const std::shared_ptr<gpu::Context>& context, std::size_t pixels) {
    RaycastBuffers b;
    for (auto [buffer, bytes] : {std::pair{&b.vertices, pixels * 16}, std::pair{&b.normals, pixels * 16},
                                 std::pair{&b.shaded, pixels * 4}, std::pair{&b.colors, pixels * 4}}) {
      auto created = gpu::Buffer::create(context, bytes);
      if (!created) return created.error();
      *buffer = std::move(*created);
    }
    return b;
  }
};

Result<Vec4Image> download_map(const gpu::Buffer& buffer, int width, int height) {
  Vec4Image image;
  image.width = width;
  image.height = height;
  image.data.resize(static_cast<std::size_t>(width) * height);
  IMUFUSION_RETURN_IF_ERROR(buffer.download(image.data.data(), image.data.size() * sizeof(Eigen::Vector4f)));
  return image;
}

}  // namespace

struct Reconstructor::Impl {
  ReconstructorConfig config;
  std::shared_ptr<gpu::Context> context;
  gpu::Preprocessor current;    // the incoming frame
  gpu::Preprocessor reference;  // the model raycast the next frame is aligned to
  gpu::CommandSequence preprocess_seq;
  gpu::CommandSequence icp_seq;
  gpu::IcpKernels icp_kernels;
  gpu::TsdfVolume volume;
  gpu::Buffer color;
  std::vector<std::uint32_t> rgba;
  RaycastBuffers model;
  std::optional<InertialNavigator> navigator;
  TrackingStateMachine machine;

  Trajectory trajectory;
  double last_constrained_time = 0;  // s: the last frame whose pose ICP fixed in all directions
  Eigen::Isometry3d T_world_reference = Eigen::Isometry3d::Identity();  // pose of the raycast
  bool has_reference = false;

  Status check_frame(double timestamp, const DepthImage& depth, const ColorImage* rgb) const {
    const Intrinsics& k = config.intrinsics;
    if (depth.width != k.width || depth.height != k.height ||
        depth.data.size() != static_cast<std::size_t>(k.width) * k.height)
      return make_error(ErrorCode::kInvalidArgument,
                        "depth frame at t=" + std::to_string(timestamp) + " is " + std::to_string(depth.width) +
                            "x" + std::to_string(depth.height) + ", the reconstructor was made for " +
                            std::to_string(k.width) + "x" + std::to_string(k.height));
    if (rgb != nullptr && (rgb->width != depth.width || rgb->height != depth.height ||
                           rgb->data.size() != depth.data.size() * 3))
      return make_error(ErrorCode::kInvalidArgument,
                        "colour frame at t=" + std::to_string(timestamp) + " is " + std::to_string(rgb->width) +
                            "x" + std::to_string(rgb->height) + ", the depth frame " +
                            std::to_string(depth.width) + "x" + std::to_string(depth.height));
    if (!std::isfinite(timestamp))
      return make_error(ErrorCode::kInvalidArgument, "frame timestamp " + std::to_string(timestamp) + " is not finite");
    if (!trajectory.empty() && !(timestamp > trajectory.back().timestamp))
      return make_error(ErrorCode::kInvalidArgument,
                        "frame timestamp " + std::to_string(timestamp) + " does not follow the previous frame's " +
                            std::to_string(trajectory.back().timestamp));
    return {};
  }

  Status add_imu(std::span<const ImuSample> imu) {
    if (!config.use_imu || imu.empty()) return {};
    return navigator->add_samples(imu);
  }

  Status preprocess(const DepthImage& depth, const ColorImage* rgb, FrameTimings& timings) {
    const auto t0 = Clock::now();
    IMUFUSION_RETURN_IF_ERROR(current.upload(depth));
    IMUFUSION_RETURN_IF_ERROR(preprocess_seq.begin());
    current.record(preprocess_seq);
    auto t = preprocess_seq.submit_and_wait();
    if (!t) return t.error();
    timings.kernels.insert(timings.kernels.end(), t->begin(), t->end());
    if (rgb != nullptr) {
      gpu::pack_rgba(*rgb, rgba);
      IMUFUSION_RETURN_IF_ERROR(color.upload(rgba.data(), rgba.size() * 4));
    }
    timings.preprocess_ms = ms_since(t0);
    return {};
  }

  Result<IntegrationStats> integrate(bool with_color, const Eigen::Isometry3d& T_world_camera,
                                     FrameTimings& timings) {
    const auto t0 = Clock::now();
    auto stats = volume.integrate(current.raw_depth_metres(), with_color ? &color : nullptr,
                                  config.intrinsics, T_world_camera, &timings.kernels);
    timings.integrate_ms = ms_since(t0);
    return stats;
  }

  Status raycast_model(const Intrinsics& k, const Eigen::Isometry3d& T_world_camera,
                       std::pair<float, float> range, const RaycastBuffers& out,
                       std::vector<KernelTiming>* timings) {
    return volume.raycast(k, T_world_camera, range.first, range.second, out.vertices, out.normals,
                          out.shaded, out.colors, timings);
  }

  std::pair<float, float> depth_range() const {
    return {config.preprocess.min_depth, config.preprocess.max_depth};
  }

  // The model seen from the frame's final pose becomes the next frame's ICP reference.
  Status update_reference(const Eigen::Isometry3d& T_world_camera, FrameTimings& timings) {
    const auto t0 = Clock::now();
    const Intrinsics& k = config.intrinsics;
    IMUFUSION_RETURN_IF_ERROR(raycast_model(k, T_world_camera, depth_range(), model, &timings.kernels));
    auto vertices = download_map(model.vertices, k.width, k.height);
    if (!vertices) return vertices.error();
    auto normals = download_map(model.normals, k.width, k.height);
    if (!normals) return normals.error();
    IMUFUSION_RETURN_IF_ERROR(reference.upload_maps(*vertices, *normals));
    T_world_reference = T_world_camera;
    has_reference = true;
    timings.raycast_ms = ms_since(t0);
    return {};
  }

  // Mean sigma(z)^2 over the frame's valid depths (m^2).
  double mean_noise_variance(const DepthImage& depth) const {
    double sum = 0;
    std::size_t n = 0;
    const double scale = 1.0 / depth.depth_scale;
    for (std::uint16_t raw : depth.data) {
      const double z = raw * scale;
      if (raw == 0 || z < config.preprocess.min_depth || z > config.preprocess.max_depth) continue;
      const double sigma = config.depth_noise_a + config.depth_noise_b * (z - config.depth_noise_z0) * (z - config.depth_noise_z0);
      sum += sigma * sigma;
      ++n;
    }
    return n > 0 ? sum / static_cast<double>(n) : 0.0;
  }

  Result<IcpResult> align(const DepthImage& depth, const Eigen::Isometry3d& T_world_seed,
                          const MotionPrediction& prediction, FrameTimings& timings) {
    const auto t0 = Clock::now();
    IcpConfig icp = config.icp;
    icp.keep_seed_in_degenerate_directions =
        config.partial_icp_with_imu && prediction.rotation_from_imu && prediction.translation_predicted;
    icp.reliability.max_residual_per_weight =
        std::max(icp.reliability.max_residual_per_weight, 2.0 * mean_noise_variance(depth));
    if (machine.recovering_or_lost()) {
      icp.max_total_iterations = std::max(icp.max_total_iterations, config.tracking.recovery_icp_iterations);
      icp.converged_rotation = std::max(icp.converged_rotation, config.recovery_converged_rotation);
      icp.converged_translation = std::max(icp.converged_translation, config.recovery_converged_translation);
    }
    gpu::GpuNormalEquationSource source(icp_kernels, icp_seq, current, reference, &timings.kernels);
    auto result = run_icp(source, icp, T_world_reference.inverse() * T_world_seed);
    timings.icp_ms = ms_since(t0);
    return result;
  }

  InertialStatus inertial_status() const { return navigator ? navigator->status() : InertialStatus{}; }
};

Reconstructor::Reconstructor(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Reconstructor::~Reconstructor() = default;
Reconstructor::Reconstructor(Reconstructor&&) noexcept = default;
Reconstructor& Reconstructor::operator=(Reconstructor&&) noexcept = default;

Result<Reconstructor> Reconstructor::create(const ReconstructorConfig& config) {
  IMUFUSION_RETURN_IF_ERROR(config.validate());
  auto context = gpu::Context::create(config.device);
  if (!context) return context.error();
  auto impl = std::make_unique<Impl>();
  Impl& m = *impl;
  m.config = config;
  m.context = *context;
  m.machine = TrackingStateMachine(config.tracking);
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
  auto icp_seq = gpu::CommandSequence::create(m.context, gpu::IcpKernels::kDispatches);
  if (!icp_seq) return icp_seq.error();
  m.icp_seq = std::move(*icp_seq);
  auto kernels = gpu::IcpKernels::create(m.context, pixels, config.preprocess.workgroup_x,
                                         config.preprocess.workgroup_y);
  if (!kernels) return kernels.error();
  m.icp_kernels = std::move(*kernels);
  auto volume = gpu::TsdfVolume::create(m.context, config.volume, config.preprocess.workgroup_x,
                                        config.preprocess.workgroup_y);
  if (!volume) return volume.error();
  m.volume = std::move(*volume);
  auto color = gpu::Buffer::create(m.context, pixels * 4);
  if (!color) return color.error();
  m.color = std::move(*color);
  auto model = RaycastBuffers::create(m.context, pixels);
  if (!model) return model.error();
  m.model = std::move(*model);
  if (config.use_imu) {
    auto navigator = InertialNavigator::create(config.inertial);
    if (!navigator) return navigator.error();
    m.navigator.emplace(std::move(*navigator));
  }
  return Reconstructor(std::move(impl));
}

Result<FrameResult> Reconstructor::track_and_fuse(double timestamp, const DepthImage& depth,
                                                  const ColorImage* color,
                                                  std::span<const ImuSample> imu) {
  Impl& m = *impl_;
  const auto t0 = Clock::now();
  IMUFUSION_RETURN_IF_ERROR(m.check_frame(timestamp, depth, color));
  IMUFUSION_RETURN_IF_ERROR(m.add_imu(imu));
  FrameResult r;
  r.index = m.trajectory.size();
  r.timestamp = timestamp;
  IMUFUSION_RETURN_IF_ERROR(m.preprocess(depth, color, r.timings));

  TrackingDecision decision;
  if (!m.machine.started() || !m.has_reference) {
    decision = m.machine.start();
    r.T_world_camera = m.config.initial_pose;
  } else {
    const StampedPose& previous = m.trajectory.back();
    if (m.navigator) r.imu = m.navigator->predict(previous.timestamp, timestamp);
    const Eigen::Isometry3d T_world_seed = previous.T_world_camera * r.imu.T_a_b;
    auto icp = m.align(depth, T_world_seed, r.imu, r.timings);
    if (!icp) return icp.error();
    const bool partial_may_fuse = timestamp - m.last_constrained_time <= m.config.max_partial_seconds;
    if (icp->partial && !partial_may_fuse && !m.machine.recovering_or_lost()) {
      char limit[32];
      std::snprintf(limit, sizeof limit, "%.3g", m.config.max_partial_seconds);
      icp->reason += std::string("; partial for more than ") + limit + " s";
    }
    r.icp_ran = true;
    r.icp = *icp;
    decision = m.machine.step(icp->reliable, icp->quality.converged, icp->partial, partial_may_fuse);
    const bool icp_pose = decision.source == PoseSource::kIcp || decision.source == PoseSource::kIcpPartial;
    r.T_world_camera = icp_pose ? m.T_world_reference * icp->T_ref_cur : T_world_seed;
    if (m.navigator)
      m.navigator->observe(previous.timestamp, timestamp, previous.T_world_camera, r.T_world_camera,
                           decision.source == PoseSource::kIcp);
  }
  if (decision.source == PoseSource::kIcp || decision.source == PoseSource::kInitial) m.last_constrained_time = timestamp;
  r.status = decision.status;
  r.source = decision.source;
  r.recovered = decision.recovered;
  if (decision.fuse) {
    auto stats = m.integrate(color != nullptr, r.T_world_camera, r.timings);
    if (!stats) return stats.error();
    r.integration = *stats;
    r.fused = true;
  }
  IMUFUSION_RETURN_IF_ERROR(m.update_reference(r.T_world_camera, r.timings));
  m.trajectory.push_back({timestamp, r.T_world_camera});
  r.inertial = m.inertial_status();
  r.timings.total_ms = ms_since(t0);
  return r;
}

Result<FrameResult> Reconstructor::fuse_with_pose(double timestamp, const DepthImage& depth,
                                                  const ColorImage* color,
                                                  const Eigen::Isometry3d& T_world_camera,
                                                  std::span<const ImuSample> imu) {
  Impl& m = *impl_;
  const auto t0 = Clock::now();
  IMUFUSION_RETURN_IF_ERROR(m.check_frame(timestamp, depth, color));
  if (!T_world_camera.matrix().allFinite())
    return make_error(ErrorCode::kInvalidArgument, "known pose at t=" + std::to_string(timestamp) + " is not finite");
  IMUFUSION_RETURN_IF_ERROR(m.add_imu(imu));
  FrameResult r;
  r.index = m.trajectory.size();
  r.timestamp = timestamp;
  r.T_world_camera = T_world_camera;
  r.status = TrackingStatus::kTracking;
  r.source = PoseSource::kKnown;
  m.last_constrained_time = timestamp;
  if (!m.trajectory.empty() && m.navigator) {
    const StampedPose& previous = m.trajectory.back();
    r.imu = m.navigator->predict(previous.timestamp, timestamp);
    m.navigator->observe(previous.timestamp, timestamp, previous.T_world_camera, T_world_camera, true);
  }
  if (!m.machine.started()) m.machine.start();
  IMUFUSION_RETURN_IF_ERROR(m.preprocess(depth, color, r.timings));
  auto stats = m.integrate(color != nullptr, T_world_camera, r.timings);
  if (!stats) return stats.error();
  r.integration = *stats;
  r.fused = true;
  m.trajectory.push_back({timestamp, T_world_camera});
  r.inertial = m.inertial_status();
  r.timings.total_ms = ms_since(t0);
  return r;
}

Result<Mesh> Reconstructor::extract_mesh(const MeshOptions& options) const {
  auto volume = snapshot();
  if (!volume) return volume.error();
  return imufusion::extract_mesh(*volume, options);
}

Result<RaycastImages> Reconstructor::raycast(const Eigen::Isometry3d& T_world_camera,
                                             std::optional<Intrinsics> intrinsics,
                                             std::optional<std::pair<float, float>> depth_range) {
  Impl& m = *impl_;
  const Intrinsics k = intrinsics.value_or(m.config.intrinsics);
  const auto range = depth_range.value_or(m.depth_range());
  if (!(range.first >= 0 && range.second > range.first))
    return make_error(ErrorCode::kInvalidArgument, "raycast depth range is empty");
  const auto pixels = static_cast<std::size_t>(k.width) * k.height;
  if (k.width <= 0 || k.height <= 0) return make_error(ErrorCode::kInvalidArgument, "raycast of an empty image");
  auto buffers = RaycastBuffers::create(m.context, pixels);
  if (!buffers) return buffers.error();
  IMUFUSION_RETURN_IF_ERROR(m.raycast_model(k, T_world_camera, range, *buffers, nullptr));
  RaycastImages out;
  auto vertices = download_map(buffers->vertices, k.width, k.height);
  if (!vertices) return vertices.error();
  auto normals = download_map(buffers->normals, k.width, k.height);
  if (!normals) return normals.error();
  auto shaded = buffers->shaded.download_as<std::uint32_t>(pixels);
  if (!shaded) return shaded.error();
  auto colors = buffers->colors.download_as<std::uint32_t>(pixels);
  if (!colors) return colors.error();
  out.vertices = std::move(*vertices);
  out.normals = std::move(*normals);
  out.shaded = gpu::unpack_rgba(*shaded, k.width, k.height);
  out.color = gpu::unpack_rgba(*colors, k.width, k.height);
  return out;
}

Result<HostVolume> Reconstructor::snapshot() const { return impl_->volume.snapshot(); }

Status Reconstructor::reset() {
  Impl& m = *impl_;
  IMUFUSION_RETURN_IF_ERROR(m.volume.reset());
  m.machine.reset();
  if (m.navigator) m.navigator->reset();
  m.trajectory.clear();
  m.has_reference = false;
  m.T_world_reference = Eigen::Isometry3d::Identity();
  return {};
}

const Trajectory& Reconstructor::trajectory() const { return impl_->trajectory; }
const ReconstructorConfig& Reconstructor::config() const { return impl_->config; }
const DeviceInfo& Reconstructor::device() const { return impl_->context->info(); }
std::uint32_t Reconstructor::allocated_blocks() const { return impl_->volume.allocated_blocks(); }
std::uint64_t Reconstructor::memory_bytes() const { return impl_->volume.config().reserved_bytes(); }
std::uint32_t Reconstructor::validation_error_count() const {
  return impl_->context->validation_error_count();
}

}  // namespace imufusion

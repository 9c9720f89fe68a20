#include "gpu/icp_kernels.hpp"

#include <cmath>
#include <string>
#include <utility>

#include "imufusion_layouts.h"

namespace imufusion::gpu {
namespace {

// Rows per workgroup of the first reduction stage: 16 per invocation of a 128-wide group.
constexpr std::uint32_t kRowsPerGroup = 2048;

}  // namespace

Result<IcpKernels> IcpKernels::create(std::shared_ptr<Context> context, std::size_t max_pixels,
                                      int workgroup_x, int workgroup_y,
                                      const DepthNoiseModel& noise, const NormalGate& gate,
                                      bool subgroups) {
  IcpKernels k;
  k.noise_ = noise;
  k.gate_ = gate;
  auto associate = ComputePipeline::create(
      context, {"icp_associate", 5, sizeof(layout::IcpAssociateParams),
                static_cast<std::uint32_t>(workgroup_x), static_cast<std::uint32_t>(workgroup_y)});
  if (!associate) return associate.error();
  k.associate_ = std::move(*associate);
  // One workgroup (of the shader's fixed 128 invocations) per grid cell; the subgroup variant
  // where the device adds across subgroups (40 % less time on lavapipe at 640x480).
  const char* reduce_shader =
      subgroups && context->info().subgroup_arithmetic ? "icp_reduce_subgroup" : "icp_reduce";
  auto reduce =
      ComputePipeline::create(context, {reduce_shader, 3, sizeof(layout::IcpReduceParams), 1, 1});
  if (!reduce) return reduce.error();
  k.reduce_ = std::move(*reduce);
  auto photometric = ComputePipeline::create(
      context, {"icp_photometric", 6, sizeof(layout::IcpPhotometricParams),
                static_cast<std::uint32_t>(workgroup_x), static_cast<std::uint32_t>(workgroup_y)});
  if (!photometric) return photometric.error();
  k.photometric_ = std::move(*photometric);
  auto photo_rows = Buffer::create(context, max_pixels * ICP_ROW_FLOATS * sizeof(float));
  if (!photo_rows) return photo_rows.error();
  k.photo_rows_ = std::move(*photo_rows);
  auto rows = Buffer::create(context, max_pixels * ICP_ROW_FLOATS * sizeof(float));
  if (!rows) return rows.error();
  k.rows_ = std::move(*rows);
  const std::size_t max_groups = (max_pixels + kRowsPerGroup - 1) / kRowsPerGroup;
  // Host-visible: the host reads the partial sums of every iteration without a transfer.
  auto partials = Buffer::create(context, max_groups * ICP_PARTIAL_STRIDE * sizeof(float), true);
  if (!partials) return partials.error();
  k.partials_ = std::move(*partials);
  auto photo_partials =
      Buffer::create(context, max_groups * ICP_PARTIAL_STRIDE * sizeof(float), true);
  if (!photo_partials) return photo_partials.error();
  k.photo_partials_ = std::move(*photo_partials);
  return k;
}

namespace {

// The fields both association kernels share: the level sizes, the reference's intrinsics and
// T_ref_cur.
template <typename Params>
Params association_params(const IcpMaps& current, const IcpMaps& reference, const Intrinsics& k,
                          const Eigen::Isometry3d& T, float max_distance) {
  Params p{};
  p.width = static_cast<std::uint32_t>(current.width);
  p.height = static_cast<std::uint32_t>(current.height);
  p.ref_width = static_cast<std::uint32_t>(reference.width);
  p.ref_height = static_cast<std::uint32_t>(reference.height);
  p.fx = static_cast<float>(k.fx);
  p.fy = static_cast<float>(k.fy);
  p.cx = static_cast<float>(k.cx);
  p.cy = static_cast<float>(k.cy);
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  p.r00 = R(0, 0), p.r01 = R(0, 1), p.r02 = R(0, 2), p.tx = t.x();
  p.r10 = R(1, 0), p.r11 = R(1, 1), p.r12 = R(1, 2), p.ty = t.y();
  p.r20 = R(2, 0), p.r21 = R(2, 1), p.r22 = R(2, 2), p.tz = t.z();
  p.max_distance = max_distance;
  return p;
}

}  // namespace

void IcpKernels::record(CommandSequence& seq, const IcpMaps& current, const IcpMaps& reference,
                        const Intrinsics& k, const Eigen::Isometry3d& T, float max_distance,
                        float min_normal_cos, int level) {
  auto params =
      association_params<layout::IcpAssociateParams>(current, reference, k, T, max_distance);
  params.min_normal_cos = min_normal_cos;
  params.noise_a = static_cast<float>(noise_.a);
  params.noise_b = static_cast<float>(noise_.b);
  params.noise_z0 = static_cast<float>(noise_.z0);
  params.noise_k = static_cast<float>(gate_.noise_k);
  params.max_noise_cos = static_cast<float>(std::cos(gate_.max_angle_deg * M_PI / 180.0));
  const std::string suffix = "[" + std::to_string(level) + "]";
  seq.dispatch(associate_,
               {current.vertices, current.normals, reference.vertices, reference.normals, &rows_},
               params, params.width, params.height, "icp_associate" + suffix);
  const std::uint32_t row_count = params.width * params.height;
  groups_ = (row_count + kRowsPerGroup - 1) / kRowsPerGroup;
  const layout::IcpReduceParams reduce{row_count, kRowsPerGroup, static_cast<float>(noise_.a),
                                       static_cast<float>(noise_.b), static_cast<float>(noise_.z0)};
  seq.dispatch(reduce_, {&rows_, current.vertices, &partials_}, reduce, groups_, 1,
               "icp_reduce" + suffix);
}

void IcpKernels::record_photometric(CommandSequence& seq, const IcpMaps& current,
                                    const IcpMaps& reference, const PhotometricMaps& colors,
                                    float huber, const Intrinsics& k, const Eigen::Isometry3d& T,
                                    float max_distance, int level) {
  auto params =
      association_params<layout::IcpPhotometricParams>(current, reference, k, T, max_distance);
  params.color_width = static_cast<std::uint32_t>(colors.current_width);
  params.color_shift = static_cast<std::uint32_t>(level);
  params.huber = huber;
  params.step = static_cast<std::uint32_t>(colors.step());
  const std::uint32_t samples_x = (params.width + params.step - 1) / params.step;
  const std::uint32_t samples_y = (params.height + params.step - 1) / params.step;
  const std::string suffix = "[" + std::to_string(level) + "]";
  seq.dispatch(photometric_,
               {current.vertices, colors.current, reference.vertices, colors.reference,
                &photo_rows_, &rows_},
               params, samples_x, samples_y, "icp_photometric" + suffix);
  const std::uint32_t row_count = samples_x * samples_y;
  photo_groups_ = (row_count + kRowsPerGroup - 1) / kRowsPerGroup;
  const layout::IcpReduceParams reduce{row_count, kRowsPerGroup, 0.0f, 0.0f, 0.0f};
  seq.dispatch(reduce_, {&photo_rows_, current.vertices, &photo_partials_}, reduce, photo_groups_,
               1, "icp_reduce_photometric" + suffix);
}

namespace {

Result<NormalEquations> read_partials(const Buffer& buffer, std::uint32_t groups) {
  std::vector<float> partials(static_cast<std::size_t>(groups) * ICP_PARTIAL_STRIDE);
  IMUFUSION_RETURN_IF_ERROR(buffer.download(partials.data(), partials.size() * sizeof(float)));
  double sums[ICP_REDUCE_VALUES] = {};
  for (std::uint32_t g = 0; g < groups; ++g)
    for (int v = 0; v < ICP_REDUCE_VALUES; ++v)
      sums[v] +=
          partials[static_cast<std::size_t>(g) * ICP_PARTIAL_STRIDE + static_cast<std::size_t>(v)];
  NormalEquations eq;
  int index = 0;
  for (int i = 0; i < 6; ++i) {
    for (int j = i; j < 6; ++j) {
      eq.AtA(i, j) = sums[index];
      eq.AtA(j, i) = sums[index];
      ++index;
    }
  }
  for (int i = 0; i < 6; ++i) eq.Atb(i) = sums[21 + i];
  eq.btb = sums[27];
  eq.inliers = static_cast<std::uint64_t>(sums[28] + 0.5);
  eq.weight_sum = sums[29];
  eq.valid_information = sums[30];
  eq.inlier_information = sums[31];
  eq.valid_pixels = static_cast<std::uint64_t>(sums[32] + 0.5);
  eq.uncovered_information = sums[33];
  eq.uncovered_pixels = static_cast<std::uint64_t>(sums[34] + 0.5);
  return eq;
}

}  // namespace

Result<NormalEquations> IcpKernels::read_equations() const {
  return read_partials(partials_, groups_);
}

Result<NormalEquations> IcpKernels::read_photometric() const {
  return read_partials(photo_partials_, photo_groups_);
}

GpuNormalEquationSource::GpuNormalEquationSource(IcpKernels& kernels, CommandSequence& seq,
                                                 const Preprocessor& current,
                                                 const Preprocessor& reference,
                                                 std::vector<KernelTiming>* timings,
                                                 int first_level, const PhotometricMaps& colors)
    : kernels_(kernels),
      seq_(seq),
      current_(current),
      reference_(reference),
      timings_(timings),
      first_level_(first_level),
      colors_(colors) {}

Result<NormalEquations> GpuNormalEquationSource::evaluate(int level,
                                                          const Eigen::Isometry3d& T_ref_cur,
                                                          float max_distance,
                                                          float min_normal_cos) {
  level += first_level_;
  const Intrinsics& kc = current_.intrinsics(level);
  const Intrinsics& kr = reference_.intrinsics(level);
  const IcpMaps cur{&current_.vertices(level), &current_.normals(level), kc.width, kc.height};
  const IcpMaps ref{&reference_.vertices(level), &reference_.normals(level), kr.width, kr.height};
  const bool photometric = colors_.config.weight > 0 && level == first_level_ &&
                           colors_.current != nullptr && colors_.reference != nullptr;
  IMUFUSION_RETURN_IF_ERROR(seq_.begin());
  kernels_.record(seq_, cur, ref, kr, T_ref_cur, max_distance, min_normal_cos, level);
  if (photometric) {
    const double sigma = colors_.sigma != nullptr ? *colors_.sigma : 0.0;
    const double huber =
        sigma > 0 ? colors_.config.huber_sigmas * sigma : colors_.config.initial_huber;
    kernels_.record_photometric(seq_, cur, ref, colors_, static_cast<float>(huber), kr, T_ref_cur,
                                max_distance, level);
  }
  auto timings = seq_.submit_and_wait();
  if (!timings) return timings.error();
  if (timings_ != nullptr) timings_->insert(timings_->end(), timings->begin(), timings->end());
  auto eq = kernels_.read_equations();
  if (!eq || !photometric) return eq;
  auto photo = kernels_.read_photometric();
  if (!photo) return photo.error();
  if (colors_.sigma != nullptr && photo->weight_sum > 0)
    *colors_.sigma = std::sqrt(photo->btb / photo->weight_sum);
  // Each sampled row stands for the pixel_step^2 pixels around it.
  const double step = colors_.step();
  add_photometric(*eq, *photo, colors_.config.weight * step * step,
                  kernels_.depth_noise().a * kernels_.depth_noise().a,
                  colors_.config.min_sigma * colors_.config.min_sigma);
  return eq;
}

}  // namespace imufusion::gpu

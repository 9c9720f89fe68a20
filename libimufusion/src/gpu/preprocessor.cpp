#include "gpu/preprocessor.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <utility>

#include "core/undistortion.hpp"
#include "imufusion_layouts.h"

namespace imufusion {

Status PreprocessConfig::validate() const {
  auto bad = [](const std::string& what) { return make_error(ErrorCode::kInvalidArgument, what); };
  if (levels < 1 || levels > 6)
    return bad("pyramid levels must be 1..6, got " + std::to_string(levels));
  if (!(min_depth >= 0 && max_depth > min_depth))
    return bad("depth range [" + std::to_string(min_depth) + ", " + std::to_string(max_depth) +
               "] is empty");
  if (bilateral_radius < 0 || bilateral_radius > 15)
    return bad("bilateral radius must be 0..15, got " + std::to_string(bilateral_radius));
  if (!(bilateral_sigma_space > 0) || !(bilateral_sigma_depth > 0))
    return bad("bilateral sigmas must be positive");
  if (!(max_jump_fraction > 0)) return bad("max_jump_fraction must be positive");
  if (workgroup_x < 1 || workgroup_y < 1) return bad("workgroup size must be positive");
  return {};
}

int bilateral_radius_at_level(const PreprocessConfig& config, int level) {
  if (config.bilateral_radius == 0) return 0;
  return std::max(1, config.bilateral_radius >> level);
}

float bilateral_sigma_space_at_level(const PreprocessConfig& config, int level) {
  return std::ldexp(config.bilateral_sigma_space, -level);
}

namespace gpu {
namespace {

std::string level_label(const char* kernel, int level) {
  return std::string(kernel) + "[" + std::to_string(level) + "]";
}

template <typename Image>
Result<Image> download_image(const Buffer& buffer, int width, int height) {
  Image image;
  image.width = width;
  image.height = height;
  image.data.resize(static_cast<std::size_t>(width) * height);
  IMUFUSION_RETURN_IF_ERROR(
      buffer.download(image.data.data(), image.data.size() * sizeof(image.data[0])));
  return image;
}

}  // namespace

Result<Preprocessor> Preprocessor::create(std::shared_ptr<Context> context,
                                          const PreprocessConfig& config,
                                          const Intrinsics& intrinsics) {
  IMUFUSION_RETURN_IF_ERROR(config.validate());
  if (intrinsics.width < (1 << config.levels) || intrinsics.height < (1 << config.levels) ||
      !(intrinsics.fx > 0) || !(intrinsics.fy > 0)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "intrinsics " + std::to_string(intrinsics.width) + "x" +
                          std::to_string(intrinsics.height) + " fx " +
                          std::to_string(intrinsics.fx) + " cannot hold " +
                          std::to_string(config.levels) + " pyramid levels");
  }
  auto sources = undistortion_sources(intrinsics);
  if (!sources) return sources.error();
  Preprocessor p;
  p.config_ = config;
  p.sources_ = std::move(*sources);
  const auto wx = static_cast<std::uint32_t>(config.workgroup_x);
  const auto wy = static_cast<std::uint32_t>(config.workgroup_y);
  auto make = [&](const char* shader, std::uint32_t push_bytes, ComputePipeline& out,
                  std::uint32_t buffers = 2) -> Status {
    auto pipeline = ComputePipeline::create(context, {shader, buffers, push_bytes, wx, wy});
    if (!pipeline) return pipeline.error();
    out = std::move(*pipeline);
    return {};
  };
  IMUFUSION_RETURN_IF_ERROR(
      make("depth_to_metres", sizeof(layout::DepthToMetresParams), p.to_metres_));
  IMUFUSION_RETURN_IF_ERROR(make("bilateral", sizeof(layout::BilateralParams), p.bilateral_));
  IMUFUSION_RETURN_IF_ERROR(
      make("pyramid_down", sizeof(layout::PyramidDownParams), p.pyramid_down_));
  IMUFUSION_RETURN_IF_ERROR(make("vertex_map", sizeof(layout::VertexMapParams), p.vertex_map_));
  IMUFUSION_RETURN_IF_ERROR(make("normal_map", sizeof(layout::NormalMapParams), p.normal_map_));
  IMUFUSION_RETURN_IF_ERROR(
      make("map_pyramid_down", sizeof(layout::PyramidDownParams), p.map_pyramid_, 4));

  auto alloc = [&](std::size_t bytes, Buffer& out, bool host_visible = false) -> Status {
    auto buffer = Buffer::create(context, bytes, host_visible);
    if (!buffer) return buffer.error();
    out = std::move(*buffer);
    return {};
  };
  const auto pixels0 = static_cast<std::size_t>(intrinsics.width) * intrinsics.height;
  // Host-visible: the frame's depth is written in place, read once by depth_to_metres.
  IMUFUSION_RETURN_IF_ERROR(alloc((pixels0 + 1) / 2 * 4, p.raw_, true));
  IMUFUSION_RETURN_IF_ERROR(alloc(pixels0 * sizeof(float), p.raw_metres_));
  for (int level = 0; level < config.levels; ++level) {
    const Intrinsics k = intrinsics.at_level(level);
    p.levels_.push_back(k);
    const auto pixels = static_cast<std::size_t>(k.width) * k.height;
    p.depth_.emplace_back();
    p.vertices_.emplace_back();
    p.normals_.emplace_back();
    IMUFUSION_RETURN_IF_ERROR(alloc(pixels * sizeof(float), p.depth_.back()));
    IMUFUSION_RETURN_IF_ERROR(alloc(pixels * 4 * sizeof(float), p.vertices_.back()));
    IMUFUSION_RETURN_IF_ERROR(alloc(pixels * 4 * sizeof(float), p.normals_.back()));
  }
  if (config.levels > 1) {
    const Intrinsics k1 = intrinsics.at_level(1);
    IMUFUSION_RETURN_IF_ERROR(
        alloc(static_cast<std::size_t>(k1.width) * k1.height * sizeof(float), p.filter_input_));
  }
  return p;
}

Status Preprocessor::submit(CommandSequence& seq, const DepthView& depth, int first_map_level) {
  IMUFUSION_RETURN_IF_ERROR(upload(depth));
  IMUFUSION_RETURN_IF_ERROR(seq.begin());
  record(seq, first_map_level);
  return seq.submit();
}

Status Preprocessor::upload(const DepthView& depth) {
  const Intrinsics& k = levels_.front();
  if (Status s = depth.check(k.width, k.height); !s.ok())
    return make_error(ErrorCode::kInvalidArgument,
                      s.error().message + " (the preprocessor's intrinsics)");
  metres_input_ = depth.format == DepthFormat::kFloatMetres;
  if (metres_input_) return upload_metres(depth);
  depth_scale_ = depth.raw_scale();
  // The shader reads two little-endian uint16 per 32-bit word; an odd pixel count leaves the last
  // half-word unused. Rows go straight into the host-visible buffer.
  auto* out = static_cast<std::uint16_t*>(raw_.mapped());
  if (out == nullptr) return make_error(ErrorCode::kInternal, "raw depth buffer is not mapped");
  const auto width = static_cast<std::size_t>(k.width);
  if (!sources_.empty()) {  // a distorted frame: each pixel from where the lens put its ray
    for (const std::int32_t s : sources_)
      *out++ = s < 0 ? std::uint16_t{0} : depth.raw(s % k.width, s / k.width);
    return {};
  }
  for (int v = 0; v < depth.height; ++v, out += width) {
    if (depth.format == DepthFormat::kUint16)
      std::memcpy(out, depth.row(v), width * sizeof(std::uint16_t));
    else
      for (int u = 0; u < depth.width; ++u) out[u] = depth.raw(u, v);  // DEPTH16 decoded
  }
  return {};
}

// Float metres skip depth_to_metres: the range test it applies is applied here, in place when
// the buffer is host-visible.
Status Preprocessor::upload_metres(const DepthView& depth) {
  const auto pixels = static_cast<std::size_t>(depth.width) * depth.height;
  float* out = static_cast<float*>(raw_metres_.mapped());
  if (out == nullptr) {
    metres_scratch_.resize(pixels);
    out = metres_scratch_.data();
  }
  const double lo = config_.min_depth, hi = config_.max_depth;
  const int width = depth.width;
  for (std::size_t i = 0; i < pixels; ++i) {
    // The pixel itself, or its source in a distorted frame (-1: none there).
    const std::int32_t s = sources_.empty() ? static_cast<std::int32_t>(i) : sources_[i];
    const double d = s < 0 ? 0.0 : depth.metres(s % width, s / width);  // 0 for none
    *out++ = d > 0 && d >= lo && d <= hi ? static_cast<float>(d) : 0.0f;
  }
  if (raw_metres_.mapped() != nullptr) return {};
  return raw_metres_.upload(metres_scratch_.data(), pixels * sizeof(float));
}

Status Preprocessor::upload_maps(CommandSequence& seq, const Vec4Image& vertices,
                                 const Vec4Image& normals) {
  const Intrinsics& k = levels_.front();
  const auto pixels = static_cast<std::size_t>(k.width) * k.height;
  if (vertices.width != k.width || vertices.height != k.height || normals.width != k.width ||
      normals.height != k.height || vertices.data.size() != pixels ||
      normals.data.size() != pixels) {
    return make_error(ErrorCode::kInvalidArgument,
                      "reference maps are " + std::to_string(vertices.width) + "x" +
                          std::to_string(vertices.height) + ", the tracker was made for " +
                          std::to_string(k.width) + "x" + std::to_string(k.height));
  }
  const auto bytes = vertices.data.size() * sizeof(Eigen::Vector4f);
  IMUFUSION_RETURN_IF_ERROR(vertices_[0].upload(vertices.data.data(), bytes));
  IMUFUSION_RETURN_IF_ERROR(normals_[0].upload(normals.data.data(), bytes));
  IMUFUSION_RETURN_IF_ERROR(seq.begin());
  record_map_pyramid(seq, 0);
  auto t = seq.submit_and_wait();
  return t ? Status{} : Status{t.error()};
}

layout::PyramidDownParams Preprocessor::pyramid_down(int level) const {
  const Intrinsics& src = levels_[static_cast<std::size_t>(level - 1)];
  const Intrinsics& dst = levels_[static_cast<std::size_t>(level)];
  return {static_cast<std::uint32_t>(src.width), static_cast<std::uint32_t>(src.height),
          static_cast<std::uint32_t>(dst.width), static_cast<std::uint32_t>(dst.height),
          config_.max_jump_fraction};
}

void Preprocessor::record_maps_from(CommandSequence& seq, const Buffer& vertices,
                                    const Buffer& normals, int first_level) const {
  const auto first = static_cast<std::size_t>(first_level);
  const std::string label = level_label("reference_copy", first_level);
  seq.copy(vertices, vertices_[first], vertices_[first].size(), label);
  seq.copy(normals, normals_[first], normals_[first].size(), label);
  record_map_pyramid(seq, first_level);
}

void Preprocessor::record_map_pyramid(CommandSequence& seq, int first_level) const {
  for (int level = first_level + 1; level < config_.levels; ++level) {
    const auto l = static_cast<std::size_t>(level);
    const layout::PyramidDownParams down = pyramid_down(level);
    seq.dispatch(map_pyramid_, {&vertices_[l - 1], &normals_[l - 1], &vertices_[l], &normals_[l]},
                 down, down.dst_width, down.dst_height, level_label("map_pyramid_down", level));
  }
}

std::uint32_t Preprocessor::maps_dispatch_count() const {
  return 2 + static_cast<std::uint32_t>(config_.levels - 1);
}

std::uint32_t Preprocessor::dispatch_count() const {
  // depth_to_metres, the level-0 copy, the bilateral filter, the pyramid and the maps.
  return 3 + static_cast<std::uint32_t>(config_.levels - 1) +
         2 * static_cast<std::uint32_t>(config_.levels);
}

void Preprocessor::record(CommandSequence& seq, int first_map_level) const {
  const Intrinsics& k0 = levels_.front();
  const auto w0 = static_cast<std::uint32_t>(k0.width);
  const auto h0 = static_cast<std::uint32_t>(k0.height);
  const layout::DepthToMetresParams metres{w0, h0, static_cast<float>(1.0 / depth_scale_),
                                           config_.min_depth, config_.max_depth};
  if (!metres_input_)
    seq.dispatch(to_metres_, {&raw_, &raw_metres_}, metres, w0, h0, "depth_to_metres");
  // The depth pyramid, filtered at first_map_level: the levels finer than it hold the unfiltered
  // pyramid (level 0 a copy of the metres), its own reduction goes to the scratch buffer and is
  // filtered from there, the coarser levels are reduced from the filtered one.
  const int filter_level = std::clamp(first_map_level, 0, config_.levels - 1);
  const auto record_filter = [&] {
    const auto f = static_cast<std::size_t>(filter_level);
    const auto wf = static_cast<std::uint32_t>(levels_[f].width);
    const auto hf = static_cast<std::uint32_t>(levels_[f].height);
    const float ss = bilateral_sigma_space_at_level(config_, filter_level);
    const float sd = config_.bilateral_sigma_depth;
    const layout::BilateralParams bilateral{wf, hf,
                                            bilateral_radius_at_level(config_, filter_level),
                                            1.0f / (2 * ss * ss), 1.0f / (2 * sd * sd)};
    seq.dispatch(bilateral_, {filter_level == 0 ? &raw_metres_ : &filter_input_, &depth_[f]},
                 bilateral, wf, hf, level_label("bilateral", filter_level));
  };
  if (filter_level == 0)
    record_filter();
  else
    seq.copy(raw_metres_, depth_[0], depth_[0].size(), "depth_copy[0]");
  for (int level = 1; level < config_.levels; ++level) {
    const auto l = static_cast<std::size_t>(level);
    const layout::PyramidDownParams down = pyramid_down(level);
    const Buffer* src = level == 1 && filter_level > 0 ? &raw_metres_ : &depth_[l - 1];
    const Buffer* dst = level == filter_level ? &filter_input_ : &depth_[l];
    seq.dispatch(pyramid_down_, {src, dst}, down, down.dst_width, down.dst_height,
                 level_label("pyramid_down", level));
    if (level == filter_level) record_filter();
  }
  for (int level = first_map_level; level < config_.levels; ++level) {
    const auto l = static_cast<std::size_t>(level);
    const Intrinsics& k = levels_[l];
    const auto w = static_cast<std::uint32_t>(k.width);
    const auto h = static_cast<std::uint32_t>(k.height);
    const layout::VertexMapParams vp{w,
                                     h,
                                     static_cast<float>(k.fx),
                                     static_cast<float>(k.fy),
                                     static_cast<float>(k.cx),
                                     static_cast<float>(k.cy)};
    seq.dispatch(vertex_map_, {&depth_[l], &vertices_[l]}, vp, w, h,
                 level_label("vertex_map", level));
    const layout::NormalMapParams np{w, h, config_.max_jump_fraction};
    seq.dispatch(normal_map_, {&vertices_[l], &normals_[l]}, np, w, h,
                 level_label("normal_map", level));
  }
}

Result<PreprocessedFrame> Preprocessor::download() const {
  PreprocessedFrame frame;
  const Intrinsics& k0 = levels_.front();
  auto raw = download_image<FloatImage>(raw_metres_, k0.width, k0.height);
  if (!raw) return raw.error();
  frame.raw_depth = std::move(*raw);
  for (int level = 0; level < config_.levels; ++level) {
    const auto l = static_cast<std::size_t>(level);
    auto d = download_image<FloatImage>(depth_[l], levels_[l].width, levels_[l].height);
    if (!d) return d.error();
    auto v = download_image<Vec4Image>(vertices_[l], levels_[l].width, levels_[l].height);
    if (!v) return v.error();
    auto n = download_image<Vec4Image>(normals_[l], levels_[l].width, levels_[l].height);
    if (!n) return n.error();
    frame.depth.push_back(std::move(*d));
    frame.vertices.push_back(std::move(*v));
    frame.normals.push_back(std::move(*n));
  }
  return frame;
}

}  // namespace gpu

struct DepthPreprocessor::Impl {
  std::shared_ptr<gpu::Context> context;
  gpu::Preprocessor kernels;
  gpu::CommandSequence seq;
};

DepthPreprocessor::DepthPreprocessor(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
DepthPreprocessor::~DepthPreprocessor() = default;
DepthPreprocessor::DepthPreprocessor(DepthPreprocessor&&) noexcept = default;
DepthPreprocessor& DepthPreprocessor::operator=(DepthPreprocessor&&) noexcept = default;

Result<DepthPreprocessor> DepthPreprocessor::create(const PreprocessConfig& config,
                                                    const Intrinsics& intrinsics,
                                                    const DeviceOptions& device) {
  auto context = gpu::Context::create(device);
  if (!context) return context.error();
  auto kernels = gpu::Preprocessor::create(*context, config, intrinsics);
  if (!kernels) return kernels.error();
  auto seq = gpu::CommandSequence::create(*context, kernels->dispatch_count());
  if (!seq) return seq.error();
  auto impl =
      std::make_unique<Impl>(Impl{std::move(*context), std::move(*kernels), std::move(*seq)});
  return DepthPreprocessor(std::move(impl));
}

Result<PreprocessedFrame> DepthPreprocessor::process(const DepthView& depth) {
  IMUFUSION_RETURN_IF_ERROR(impl_->kernels.submit(impl_->seq, depth));
  auto timings = impl_->seq.wait();
  if (!timings) return timings.error();
  auto frame = impl_->kernels.download();
  if (!frame) return frame.error();
  frame->timings = std::move(*timings);
  return frame;
}

const DeviceInfo& DepthPreprocessor::device() const { return impl_->context->info(); }
const PreprocessConfig& DepthPreprocessor::config() const { return impl_->kernels.config(); }
std::uint32_t DepthPreprocessor::validation_error_count() const {
  return impl_->context->validation_error_count();
}

}  // namespace imufusion

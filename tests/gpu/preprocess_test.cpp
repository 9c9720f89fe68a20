// GPU preprocessing kernels against their CPU references (devkit/src/reference), on odd image sizes
// so that partial workgroups run. Each kernel is checked on the same input the GPU kernel saw:
//   depth_to_metres: identical validity, |gpu - ref| <= 1e-6 m (float multiply vs double divide);
//   bilateral, pyramid_down: identical validity, |gpu - ref| <= 1e-5 m (float vs double exp/sums);
//   vertex_map: identical validity, |gpu - ref| <= 1e-5 m per coordinate;
//   normal_map: identical validity, |gpu - ref| <= 1e-4 per component (unit vectors).
// The whole chain is also compared with the reference chain: validity may differ on at most 0.5%
// of pixels (float rounding moves a few comparisons at discontinuity thresholds), values as above
// with 1e-4 m / 1e-3.

#include "imufusion/preprocess.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>

#include "core/undistortion.hpp"
#include "gpu/preprocessor.hpp"
#include "gpu_test_env.hpp"
#include "reference/map_pyramid.hpp"
#include "reference/preprocess_reference.hpp"
#include "vk/command_sequence.hpp"

namespace imufusion {
namespace {

using test::GpuTest;

Intrinsics test_intrinsics(int width, int height) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  k.fx = 0.8 * width;
  k.fy = 0.8 * width;
  k.cx = (width - 1) / 2.0 + 1.3;
  k.cy = (height - 1) / 2.0 - 0.7;
  return k;
}

// A tilted plane at ~2 m with a box step (a depth discontinuity), a sphere in front, random holes,
// noise and a few out-of-range pixels.
DepthImage test_depth(const Intrinsics& k, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  DepthImage depth;
  depth.width = k.width;
  depth.height = k.height;
  depth.depth_scale = 5000.0;
  depth.data.resize(static_cast<std::size_t>(k.width) * k.height);
  const Eigen::Vector3d centre(0.1, -0.05, 1.2);
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      double z = 2.0 + 0.4 * ray.x() - 0.2 * ray.y();  // plane z = 2 + 0.4x - 0.2y (per unit z)
      z = 2.0 / (1.0 - 0.4 * ray.x() + 0.2 * ray.y());
      if (u > k.width * 2 / 3 && v < k.height / 2) z -= 0.5;  // a box face 0.5 m closer
      const double b = -2 * ray.dot(centre), a = ray.squaredNorm();
      const double c = centre.squaredNorm() - 0.25 * 0.25;
      const double disc = b * b - 4 * a * c;
      if (disc > 0) z = std::min(z, (-b - std::sqrt(disc)) / (2 * a));
      z += 0.003 * (unit(rng) - 0.5);
      std::uint16_t raw = static_cast<std::uint16_t>(std::lround(z * depth.depth_scale));
      const double r = unit(rng);
      if (r < 0.04)
        raw = 0;  // dropout
      else if (r < 0.05)
        raw = 30000;  // 6 m: beyond max_depth
      depth.data[static_cast<std::size_t>(v) * k.width + u] = raw;
    }
  }
  return depth;
}

void expect_depth_near(const FloatImage& gpu, const FloatImage& ref, double tol, const char* what) {
  ASSERT_EQ(gpu.width, ref.width);
  ASSERT_EQ(gpu.height, ref.height);
  int validity_mismatch = 0, value_mismatch = 0;
  for (std::size_t i = 0; i < gpu.data.size(); ++i) {
    if ((gpu.data[i] > 0) != (ref.data[i] > 0))
      ++validity_mismatch;
    else if (std::abs(double(gpu.data[i]) - ref.data[i]) > tol)
      ++value_mismatch;
  }
  EXPECT_EQ(validity_mismatch, 0) << what;
  EXPECT_EQ(value_mismatch, 0) << what;
}

void expect_vectors_near(const Vec4Image& gpu, const Vec4Image& ref, double tol, const char* what,
                         double max_validity_mismatch_fraction = 0.0) {
  ASSERT_EQ(gpu.width, ref.width);
  ASSERT_EQ(gpu.height, ref.height);
  int validity_mismatch = 0, value_mismatch = 0, valid = 0;
  for (std::size_t i = 0; i < gpu.data.size(); ++i) {
    const bool g = gpu.data[i].w() > 0, r = ref.data[i].w() > 0;
    valid += r ? 1 : 0;
    if (g != r)
      ++validity_mismatch;
    else if (g && (gpu.data[i] - ref.data[i]).cwiseAbs().maxCoeff() > tol)
      ++value_mismatch;
  }
  EXPECT_GT(valid, 0) << what << ": the test input must produce valid entries";
  EXPECT_LE(validity_mismatch, max_validity_mismatch_fraction * double(gpu.data.size())) << what;
  EXPECT_EQ(value_mismatch, 0) << what;
}

// Runs the whole preprocessing chain on the GPU and downloads its results (and timings).
Result<PreprocessedFrame> run_on_gpu(const std::shared_ptr<gpu::Context>& context,
                                     const PreprocessConfig& config, const Intrinsics& k,
                                     const DepthImage& raw, int first_map_level = 0) {
  auto kernels = gpu::Preprocessor::create(context, config, k);
  if (!kernels) return kernels.error();
  auto seq = gpu::CommandSequence::create(context, kernels->dispatch_count());
  if (!seq) return seq.error();
  IMUFUSION_RETURN_IF_ERROR(kernels->upload(raw));
  IMUFUSION_RETURN_IF_ERROR(seq->begin());
  kernels->record(*seq, first_map_level);
  auto timings = seq->submit_and_wait();
  if (!timings) return timings.error();
  auto frame = kernels->download();
  if (!frame) return frame.error();
  frame->timings = std::move(*timings);
  return frame;
}

class PreprocessGpuTest : public GpuTest,
                          public ::testing::WithParamInterface<std::pair<int, int>> {};

TEST_P(PreprocessGpuTest, EachKernelMatchesItsReference) {
  const auto [wx, wy] = GetParam();
  const Intrinsics k = test_intrinsics(97, 61);
  PreprocessConfig config;
  config.workgroup_x = wx;
  config.workgroup_y = wy;
  const DepthImage raw = test_depth(k, 7);
  auto gpu = run_on_gpu(context_, config, k, raw);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  EXPECT_EQ(gpu->timings.size(), 2u + 2u + 6u);

  const FloatImage metres = reference::depth_to_metres(raw, config.min_depth, config.max_depth);
  expect_depth_near(gpu->raw_depth, metres, 1e-6, "depth_to_metres");
  expect_depth_near(
      gpu->depth[0],
      reference::bilateral(gpu->raw_depth, config.bilateral_radius, config.bilateral_sigma_space,
                           config.bilateral_sigma_depth),
      1e-5, "bilateral");
  for (int level = 0; level < config.levels; ++level) {
    const auto l = static_cast<std::size_t>(level);
    if (level > 0) {
      expect_depth_near(gpu->depth[l],
                        reference::pyramid_down(gpu->depth[l - 1], config.max_jump_fraction), 1e-5,
                        "pyramid_down");
    }
    expect_vectors_near(gpu->vertices[l], reference::vertex_map(gpu->depth[l], k.at_level(level)),
                        1e-5, "vertex_map");
    expect_vectors_near(gpu->normals[l],
                        reference::normal_map(gpu->vertices[l], config.max_jump_fraction), 1e-4,
                        "normal_map");
  }
}

INSTANTIATE_TEST_SUITE_P(Workgroups, PreprocessGpuTest,
                         ::testing::Values(std::pair{16, 16}, std::pair{8, 8}, std::pair{32, 4}));

TEST_F(GpuTest, WholeChainMatchesReferenceChain) {
  const Intrinsics k = test_intrinsics(161, 117);
  const PreprocessConfig config;
  const DepthImage raw = test_depth(k, 11);
  auto gpu = run_on_gpu(context_, config, k, raw);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  const PreprocessedFrame ref = reference::preprocess(raw, k, config);
  ASSERT_EQ(gpu->depth.size(), 3u);
  for (std::size_t l = 0; l < 3; ++l) {
    EXPECT_EQ(gpu->depth[l].width, k.at_level(static_cast<int>(l)).width);
    expect_depth_near(gpu->depth[l], ref.depth[l], 1e-4, "chain depth");
    expect_vectors_near(gpu->vertices[l], ref.vertices[l], 1e-4, "chain vertices");
    expect_vectors_near(gpu->normals[l], ref.normals[l], 1e-3, "chain normals", 0.005);
  }
}

// Tracking at a coarser level filters there: the GPU chain matches the reference's, and the
// filter runs once, at that level, with the radius halved per level.
TEST_F(GpuTest, ChainFilteredAtTheFirstMapLevelMatchesReference) {
  const Intrinsics k = test_intrinsics(161, 117);
  const PreprocessConfig config;
  const DepthImage raw = test_depth(k, 12);
  for (int first = 1; first <= 2; ++first) {
    auto gpu = run_on_gpu(context_, config, k, raw, first);
    ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
    const PreprocessedFrame ref = reference::preprocess(raw, k, config, first);
    for (int level = 0; level < config.levels; ++level) {
      const auto l = static_cast<std::size_t>(level);
      expect_depth_near(gpu->depth[l], ref.depth[l], 1e-4, "depth");
      if (level < first) continue;
      expect_vectors_near(gpu->vertices[l], ref.vertices[l], 1e-4, "vertices");
      expect_vectors_near(gpu->normals[l], ref.normals[l], 1e-3, "normals", 0.005);
    }
    int filters = 0;
    for (const KernelTiming& t : gpu->timings) {
      if (t.kernel.rfind("bilateral", 0) != 0) continue;
      ++filters;
      EXPECT_EQ(t.kernel, "bilateral[" + std::to_string(first) + "]");
    }
    EXPECT_EQ(filters, 1);
    // Above the filter's level the depth is the unfiltered pyramid: level 0 is the raw metres.
    expect_depth_near(gpu->depth[0], ref.raw_depth, 1e-6, "level 0 unfiltered");
  }
  EXPECT_EQ(bilateral_radius_at_level(config, 0), 3);
  EXPECT_EQ(bilateral_radius_at_level(config, 1), 1);
  EXPECT_EQ(bilateral_radius_at_level(config, 2), 1);
  EXPECT_FLOAT_EQ(bilateral_sigma_space_at_level(config, 1), config.bilateral_sigma_space / 2);
}

TEST_F(GpuTest, InvalidPixelsStayInvalidAndNormalsFaceTheCamera) {
  const Intrinsics k = test_intrinsics(97, 61);
  const DepthImage raw = test_depth(k, 3);
  auto gpu = run_on_gpu(context_, PreprocessConfig{}, k, raw);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  for (std::size_t i = 0; i < raw.data.size(); ++i) {
    if (gpu->raw_depth.data[i] == 0) {
      EXPECT_EQ(gpu->depth[0].data[i], 0.0f);
      EXPECT_EQ(gpu->normals[0].data[i].w(), 0.0f);
    }
  }
  for (const Vec4Image& normals : gpu->normals) {
    for (std::size_t i = 0; i < normals.data.size(); ++i) {
      if (normals.data[i].w() == 0) continue;
      EXPECT_NEAR(normals.data[i].head<3>().norm(), 1.0, 1e-5);
    }
  }
  // The vertex at a valid pixel faces its normal: n . v < 0.
  for (std::size_t i = 0; i < gpu->normals[0].data.size(); ++i) {
    if (gpu->normals[0].data[i].w() == 0) continue;
    EXPECT_LT(gpu->normals[0].data[i].head<3>().dot(gpu->vertices[0].data[i].head<3>()), 0.0f);
  }
}

TEST_F(GpuTest, PyramidDoesNotAverageAcrossDiscontinuities) {
  // Left half at 1 m, right half at 3 m, split inside a 2x2 block (odd column 5 of 12).
  Intrinsics k = test_intrinsics(12, 8);
  DepthImage raw;
  raw.width = 12;
  raw.height = 8;
  raw.data.resize(96);
  for (int v = 0; v < 8; ++v)
    for (int u = 0; u < 12; ++u)
      raw.data[static_cast<std::size_t>(v * 12 + u)] = u <= 4 ? 5000 : 15000;
  PreprocessConfig config;
  config.levels = 2;
  config.bilateral_radius = 0;
  auto gpu = run_on_gpu(context_, config, k, raw);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  const FloatImage& half = gpu->depth[1];
  for (int v = 0; v < half.height; ++v) {
    EXPECT_FLOAT_EQ(half.at(1, v), 1.0f);
    EXPECT_FLOAT_EQ(half.at(2, v), 1.0f) << "the block straddling the edge keeps its near side";
    EXPECT_FLOAT_EQ(half.at(3, v), 3.0f);
  }
}

// The model raycast's maps become the ICP reference on the GPU (copy + map_pyramid_down): the
// same pyramid as the host rule core/map_pyramid.cpp, on an odd size with holes and a step:
// identical validity, 1e-6 m / 1e-6 per component (a GPU may divide by a reciprocal).
TEST_F(GpuTest, ReferencePyramidFromGpuMapsMatchesTheHostRule) {
  const Intrinsics k = test_intrinsics(97, 61);
  const PreprocessConfig config;
  auto frame = run_on_gpu(context_, config, k, test_depth(k, 5));
  ASSERT_TRUE(frame.ok()) << frame.error().describe();
  const Vec4Image& vertices = frame->vertices[0];
  const Vec4Image& normals = frame->normals[0];
  const auto bytes = vertices.data.size() * sizeof(Eigen::Vector4f);
  auto v = gpu::Buffer::create(context_, bytes), n = gpu::Buffer::create(context_, bytes);
  ASSERT_TRUE(v.ok() && n.ok());
  ASSERT_TRUE(v->upload(vertices.data.data(), bytes).ok());
  ASSERT_TRUE(n->upload(normals.data.data(), bytes).ok());
  auto reference = gpu::Preprocessor::create(context_, config, k);
  ASSERT_TRUE(reference.ok());
  auto seq = gpu::CommandSequence::create(context_, reference->maps_dispatch_count());
  ASSERT_TRUE(seq.ok());
  ASSERT_TRUE(seq->begin().ok());
  reference->record_maps_from(*seq, *v, *n);
  auto timings = seq->submit_and_wait();
  ASSERT_TRUE(timings.ok()) << timings.error().describe();
  EXPECT_EQ(timings->size(), reference->maps_dispatch_count());
  auto gpu = reference->download();
  ASSERT_TRUE(gpu.ok());
  const auto host = build_map_pyramid(vertices, normals, config.levels, config.max_jump_fraction);
  ASSERT_EQ(gpu->vertices.size(), host.size());
  for (std::size_t l = 0; l < host.size(); ++l) {
    expect_vectors_near(gpu->vertices[l], host[l].vertices, 1e-6, "reference vertices");
    expect_vectors_near(gpu->normals[l], host[l].normals, 1e-6, "reference normals");
  }
  // Half-size maps (tracking at level 1) fill level 1 and the levels below it.
  const auto half =
      build_map_pyramid(gpu->vertices[1], gpu->normals[1], 2, config.max_jump_fraction);
  const auto half_bytes = gpu->vertices[1].data.size() * sizeof(Eigen::Vector4f);
  ASSERT_TRUE(v->upload(gpu->vertices[1].data.data(), half_bytes).ok());
  ASSERT_TRUE(n->upload(gpu->normals[1].data.data(), half_bytes).ok());
  ASSERT_TRUE(seq->begin().ok());
  reference->record_maps_from(*seq, *v, *n, 1);
  ASSERT_TRUE(seq->submit_and_wait().ok());
  auto gpu_half = reference->download();
  ASSERT_TRUE(gpu_half.ok());
  for (std::size_t l = 1; l < 3; ++l) {
    expect_vectors_near(gpu_half->vertices[l], half[l - 1].vertices, 1e-6, "half-size vertices");
    expect_vectors_near(gpu_half->normals[l], half[l - 1].normals, 1e-6, "half-size normals");
  }
}

TEST_F(GpuTest, WrongImageSizeIsAnError) {
  const Intrinsics k = test_intrinsics(97, 61);
  auto kernels = gpu::Preprocessor::create(context_, PreprocessConfig{}, k);
  ASSERT_TRUE(kernels.ok());
  const DepthImage raw = test_depth(test_intrinsics(96, 61), 1);
  const Status status = kernels->upload(raw);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(status.error().message.find("96x61"), std::string::npos) << status.error().message;
}

// A tilted plane seen through a lens with distortion: the frame as the sensor gives it (each
// pixel the plane's depth along the ray the lens bends into it) comes out of preprocessing as the
// pinhole image of the plane, in uint16 and in float metres alike; read as a pinhole it does not.
TEST(DepthPreprocessorFacade, DistortedFramesBecomeThePinholeImage) {
  std::string reason;
  if (!test::gpu_context(&reason)) GTEST_SKIP() << reason;
  Intrinsics k{150.0, 151.0, 80.5, 58.5, 160, 120, {-0.25, 0.08, 0.002, -0.001, 0.0}};
  // Plane n . X = 1.2 m: its z-depth on the ray through normalized (x, y).
  const Eigen::Vector3d n = Eigen::Vector3d(0.25, -0.15, 1.0).normalized();
  const auto plane_z = [&](double x, double y) { return 1.2 / (n.x() * x + n.y() * y + n.z()); };
  DepthImage distorted;
  distorted.width = k.width;
  distorted.height = k.height;
  distorted.depth_scale = 5000.0;
  std::vector<float> distorted_metres;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      // The undistorted ray the lens puts at (u, v), by fixed-point iteration.
      const double xd = (u - k.cx) / k.fx, yd = (v - k.cy) / k.fy;
      double x = xd, y = yd;
      for (int i = 0; i < 50; ++i) {
        double px = 0, py = 0;
        distort_normalized(k, x, y, &px, &py);
        x += xd - px;
        y += yd - py;
      }
      const double z = plane_z(x, y);
      distorted.data.push_back(static_cast<std::uint16_t>(std::lround(z * 5000.0)));
      distorted_metres.push_back(static_cast<float>(z));
    }
  }
  const auto pinhole_errors = [&](const FloatImage& depth, std::size_t* invalid) {
    std::size_t large = 0;
    *invalid = 0;
    for (int v = 0; v < k.height; ++v) {
      for (int u = 0; u < k.width; ++u) {
        const float d = depth.data[static_cast<std::size_t>(v * k.width + u)];
        if (d <= 0) {
          ++*invalid;
          continue;
        }
        // Half a pixel's slope of this plane, plus the 0.2 mm depth step.
        const double z = plane_z((u - k.cx) / k.fx, (v - k.cy) / k.fy);
        if (std::abs(d - z) > 0.003 * z + 0.0002) ++large;
      }
    }
    return large;
  };
  auto sources = undistortion_sources(k);
  ASSERT_TRUE(sources.ok());
  std::size_t outside = 0;
  for (std::int32_t s : *sources) outside += s < 0 ? 1 : 0;

  auto pre = DepthPreprocessor::create(PreprocessConfig{}, k);
  ASSERT_TRUE(pre.ok()) << pre.error().describe();
  for (const DepthView& view :
       {DepthView(distorted), DepthView::metres(distorted_metres.data(), k.width, k.height)}) {
    auto frame = pre->process(view);
    ASSERT_TRUE(frame.ok()) << frame.error().describe();
    std::size_t invalid = 0;
    EXPECT_EQ(pinhole_errors(frame->raw_depth, &invalid), 0u);
    EXPECT_EQ(invalid, outside);
  }
  Intrinsics pinhole = k;
  pinhole.distortion = {0, 0, 0, 0, 0};
  auto plain = DepthPreprocessor::create(PreprocessConfig{}, pinhole);
  ASSERT_TRUE(plain.ok());
  auto frame = plain->process(distorted);
  ASSERT_TRUE(frame.ok());
  std::size_t invalid = 0;
  EXPECT_GT(pinhole_errors(frame->raw_depth, &invalid), std::size_t(k.width * k.height) / 10);
}

TEST(DepthPreprocessorFacade, ProcessesWithValidationAndReportsTimings) {
  std::string reason;
  if (!test::gpu_context(&reason)) GTEST_SKIP() << reason;
  const Intrinsics k = test_intrinsics(97, 61);
  DeviceOptions device;
  device.validation = true;
  auto pre = DepthPreprocessor::create(PreprocessConfig{}, k, device);
  ASSERT_TRUE(pre.ok()) << pre.error().describe();
  auto frame = pre->process(test_depth(k, 5));
  ASSERT_TRUE(frame.ok()) << frame.error().describe();
  EXPECT_EQ(frame->depth.size(), 3u);
  EXPECT_EQ(frame->timings.size(), 2u + 2u + 6u);
  if (pre->device().timestamps) {
    for (const KernelTiming& t : frame->timings) EXPECT_GE(t.gpu_ms, 0.0) << t.kernel;
  }
  EXPECT_EQ(pre->validation_error_count(), 0u);
}

}  // namespace
}  // namespace imufusion

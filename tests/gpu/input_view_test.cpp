// Depth and colour views (image_view.hpp) through the Reconstructor and the preprocessor:
//   a uint16 view with padded rows gives bit-identical poses to the packed DepthImage;
//   float metres preprocess as the uint16 frame they were made from (unfiltered depth: identical
//   validity, |diff| <= 2e-6 m; filtered levels: at most 0.1% of pixels beyond that, where a
//   rounding flips the bilateral's or the pyramid's edge test); over 12 frames that rounding moves
//   ICP's iterates, so the scans' poses agree within 3 mm / 0.2 deg and the float scan is as
//   accurate (max position error + 1 mm); DEPTH16 (confidence bits set) preprocesses as the same
//   millimetres in a uint16 frame; a strided BGRA colour view fuses the same colours as the packed
//   RGB image; views with a bad stride, a null pointer, a wrong size or a short buffer are refused
//   with the actual and expected values in the message.

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "imufusion/preprocess.hpp"
#include "reconstructor_test_support.hpp"

namespace imufusion::test {
namespace {

constexpr std::size_t kFrames = 12;
constexpr int kPad = 7;  // pixels of padding after each row

// `image` copied into rows kPad pixels longer, the padding filled with garbage.
std::vector<std::uint16_t> padded_rows(const DepthImage& image) {
  const auto w = static_cast<std::size_t>(image.width);
  std::vector<std::uint16_t> rows((w + kPad) * static_cast<std::size_t>(image.height), 0xBEEF);
  for (std::size_t v = 0; v < static_cast<std::size_t>(image.height); ++v)
    std::memcpy(&rows[v * (w + kPad)], &image.data[v * w], w * 2);
  return rows;
}

std::vector<float> to_metres(const DepthImage& image) {
  std::vector<float> m(image.data.size());
  for (std::size_t i = 0; i < m.size(); ++i)
    m[i] = static_cast<float>(image.data[i] / image.depth_scale);
  return m;
}

class InputViewTest : public ReconstructorTest {
 protected:
  // Tracks the first kFrames frames, each depth passed through `view_of(i)`.
  std::vector<FrameResult> scan(const std::function<DepthView(std::size_t)>& view_of) {
    Reconstructor rec = make(config(true, 8));
    std::vector<FrameResult> results;
    for (std::size_t i = 0; i < kFrames && i < frames_.size(); ++i) {
      auto r = rec.track_and_fuse(frames_[i].timestamp, view_of(i), nullptr, frames_[i].imu);
      EXPECT_TRUE(r.ok()) << r.error().describe();
      if (!r.ok()) break;
      results.push_back(*r);
    }
    EXPECT_EQ(results.size(), kFrames);
    return results;
  }

  Result<PreprocessedFrame> preprocess(const DepthView& depth) {
    DeviceOptions device;
    device.selector = context_->info().name;
    auto pre = DepthPreprocessor::create(PreprocessConfig{}, config(false, 8).intrinsics, device);
    if (!pre) return pre.error();
    return pre->process(depth);
  }
};

TEST_F(InputViewTest, StridedUint16ViewGivesThePackedImagesPoses) {
  const std::vector<FrameResult> packed =
      scan([&](std::size_t i) { return frames_[i].depth.view(); });
  std::vector<std::vector<std::uint16_t>> rows;
  for (std::size_t i = 0; i < kFrames; ++i) rows.push_back(padded_rows(frames_[i].depth));
  const std::vector<FrameResult> strided = scan([&](std::size_t i) {
    const DepthImage& d = frames_[i].depth;
    return DepthView::uint16(rows[i].data(), d.width, d.height, d.depth_scale,
                             (static_cast<std::size_t>(d.width) + kPad) * 2);
  });
  ASSERT_EQ(packed.size(), strided.size());
  for (std::size_t i = 0; i < packed.size(); ++i) {
    EXPECT_EQ(packed[i].status, strided[i].status) << "frame " << i;
    EXPECT_TRUE(packed[i].T_world_camera.matrix() == strided[i].T_world_camera.matrix())
        << "frame " << i;
  }
}

TEST_F(InputViewTest, FloatMetresMatchTheUint16Frame) {
  const DepthImage& d = frames_[5].depth;
  const std::vector<float> metres = to_metres(d);
  auto a = preprocess(d);
  auto b = preprocess(DepthView::metres(metres.data(), d.width, d.height));
  ASSERT_TRUE(a.ok()) << a.error().describe();
  ASSERT_TRUE(b.ok()) << b.error().describe();
  const auto differing = [](const FloatImage& x, const FloatImage& y) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < x.data.size(); ++i)
      n += ((x.data[i] > 0) != (y.data[i] > 0) || std::abs(x.data[i] - y.data[i]) > 2e-6f) ? 1 : 0;
    return n;
  };
  EXPECT_EQ(differing(a->raw_depth, b->raw_depth), 0u);
  for (std::size_t l = 0; l < a->depth.size(); ++l)  // a rounding may flip an edge test
    EXPECT_LE(differing(a->depth[l], b->depth[l]), a->depth[l].data.size() / 1000) << l;
  std::vector<std::vector<float>> kept;
  for (std::size_t i = 0; i < kFrames; ++i) kept.push_back(to_metres(frames_[i].depth));
  const std::vector<FrameResult> from_raw =
      scan([&](std::size_t i) { return frames_[i].depth.view(); });
  const std::vector<FrameResult> from_metres =
      scan([&](std::size_t i) { return DepthView::metres(kept[i].data(), d.width, d.height); });
  ASSERT_EQ(from_raw.size(), from_metres.size());
  double raw_error = 0, metres_error = 0;
  for (std::size_t i = 0; i < from_raw.size(); ++i) {
    const Eigen::Isometry3d& p = from_raw[i].T_world_camera;
    const Eigen::Isometry3d& q = from_metres[i].T_world_camera;
    EXPECT_LT((p.translation() - q.translation()).norm(), 3e-3) << "frame " << i;
    EXPECT_LT(rotation_deg(p, q), 0.2) << "frame " << i;
    raw_error = std::max(raw_error, position_error({from_raw[i].timestamp, p}));
    metres_error = std::max(metres_error, position_error({from_metres[i].timestamp, q}));
  }
  EXPECT_LT(metres_error, raw_error + 1e-3);  // as accurate against the ground truth
}

TEST_F(InputViewTest, Depth16PreprocessesAsItsMillimetres) {
  const DepthImage& d = frames_[5].depth;
  DepthImage mm = d;
  mm.depth_scale = 1000.0;
  std::vector<std::uint16_t> depth16(d.data.size());
  for (std::size_t i = 0; i < d.data.size(); ++i) {
    mm.data[i] = static_cast<std::uint16_t>(std::min(8191.0, std::round(d.data[i] / 5.0)));
    const std::uint16_t confidence = i % 3 == 0 ? 0 : (i % 3 == 1 ? 5 : 1);  // 1: 0%
    if (confidence == 1) mm.data[i] = 0;
    depth16[i] = static_cast<std::uint16_t>((confidence << 13) | (mm.data[i] & 0x1FFF));
  }
  auto a = preprocess(mm);
  auto b = preprocess(DepthView::depth16(depth16.data(), d.width, d.height));
  ASSERT_TRUE(a.ok()) << a.error().describe();
  ASSERT_TRUE(b.ok()) << b.error().describe();
  EXPECT_EQ(a->raw_depth.data, b->raw_depth.data);
  EXPECT_EQ(a->depth[0].data, b->depth[0].data);
}

TEST_F(InputViewTest, StridedBgraColourFusesTheSameColours) {
  const DepthImage& d = frames_[0].depth;
  ColorImage rgb{d.width, d.height, {}};
  const std::size_t stride = static_cast<std::size_t>(d.width) * 4 + 12;
  std::vector<std::uint8_t> bgra(stride * static_cast<std::size_t>(d.height), 0x55);
  for (int v = 0; v < d.height; ++v) {
    for (int u = 0; u < d.width; ++u) {
      const std::uint8_t r = static_cast<std::uint8_t>(u * 3), g = static_cast<std::uint8_t>(v * 2),
                         b = static_cast<std::uint8_t>(u + v);
      rgb.data.insert(rgb.data.end(), {r, g, b});
      std::uint8_t* p =
          &bgra[static_cast<std::size_t>(v) * stride + 4 * static_cast<std::size_t>(u)];
      p[0] = b, p[1] = g, p[2] = r, p[3] = 0x77;
    }
  }
  const ColorView view{bgra.data(), d.width, d.height, stride, ColorFormat::kBgra8, bgra.size()};
  std::vector<ColorImage> seen;
  for (const ColorInput color : {ColorInput(&rgb), ColorInput(view)}) {
    Reconstructor rec = make(config(false, 8));
    const Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    ASSERT_TRUE(rec.fuse_with_pose(frames_[0].timestamp, d, color, pose).ok());
    auto images = rec.raycast(pose);
    ASSERT_TRUE(images.ok()) << images.error().describe();
    seen.push_back(images->color);
  }
  EXPECT_EQ(seen[0].data, seen[1].data);
  std::size_t coloured = 0;
  for (std::uint8_t c : seen[0].data) coloured += c != 0 ? 1 : 0;
  EXPECT_GT(coloured, seen[0].data.size() / 4);  // the comparison saw colour, not black
}

TEST_F(InputViewTest, BadViewsAreRefusedWithActualAndExpectedValues) {
  Reconstructor rec = make(config(false, 8));
  const DepthImage& d = frames_[0].depth;
  const auto refused = [&](const DepthView& depth, ColorInput color, const std::string& words) {
    auto r = rec.track_and_fuse(frames_[0].timestamp, depth, color);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find(words), std::string::npos) << r.error().message;
  };
  refused(DepthView::uint16(d.data.data(), d.width, d.height, 5000.0, 318), nullptr,
          "row stride is 318 bytes, expected a multiple of 2 of at least 320");
  refused(DepthView::uint16(nullptr, d.width, d.height, 5000.0), nullptr, "null data pointer");
  refused(DepthView::uint16(d.data.data(), 159, d.height, 5000.0), nullptr,
          "is 159x120, expected 160x120");
  DepthImage short_image = d;
  short_image.data.resize(100);
  refused(short_image, nullptr,
          "buffer holds 200 bytes, 160x120 at a row stride of 320 bytes "
          "needs 38400");
  ColorImage small{80, 60, std::vector<std::uint8_t>(80 * 60 * 3)};
  refused(d, &small, "colour frame is 80x60, expected 160x120");
  const ColorView odd{small.data.data(), d.width, d.height, 481, ColorFormat::kRgb8, 0};
  refused(d, odd, "row stride is 481 bytes, expected a multiple of 3 of at least 480");
  EXPECT_TRUE(rec.track_and_fuse(frames_[0].timestamp, d).ok());  // refusals changed nothing
}

}  // namespace
}  // namespace imufusion::test

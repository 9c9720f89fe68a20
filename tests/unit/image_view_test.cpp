// DepthView / ColorView on the host: pixels read through a row stride, DEPTH16's confidence
// bits, colour channel orders, and the checks' messages (actual and expected values).

#include "imufusion/image_view.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "imufusion/types.hpp"

namespace imufusion {
namespace {

TEST(ImageView, StridedUint16AndFloatPixelsReadTheirRows) {
  // 3x2 pixels in rows of 5 (stride 10 bytes), padding 9999.
  const std::vector<std::uint16_t> raw{1000, 0, 3000, 9999, 9999, 4000, 5000, 6000, 9999, 9999};
  const DepthView d = DepthView::uint16(raw.data(), 3, 2, 1000.0, 10);
  EXPECT_TRUE(d.check(3, 2).ok());
  EXPECT_EQ(d.raw(2, 0), 3000);
  EXPECT_EQ(d.raw(0, 1), 4000);
  EXPECT_DOUBLE_EQ(d.metres(1, 1), 5.0);
  EXPECT_EQ(d.metres(1, 0), 0.0);
  const std::vector<float> m{1.5f, NAN, -1.0f, 0.0f, 2.5f, 0.0f};
  const DepthView f = DepthView::metres(m.data(), 2, 2, 12);  // rows of 3 floats
  EXPECT_DOUBLE_EQ(f.metres(0, 0), 1.5);
  EXPECT_EQ(f.metres(1, 0), 0.0);  // NaN: none
  EXPECT_EQ(f.metres(0, 1), 0.0);  // the row starts at index 3
  EXPECT_DOUBLE_EQ(f.metres(1, 1), 2.5);
}

TEST(ImageView, Depth16KeepsTheRangeUnlessConfidenceIsZeroPercent) {
  const auto px = [](int confidence, int mm) { return std::uint16_t(confidence << 13 | mm); };
  const std::vector<std::uint16_t> raw{px(0, 1234), px(1, 1234), px(7, 8191), px(2, 1)};
  const DepthView d = DepthView::depth16(raw.data(), 4, 1);
  EXPECT_EQ(d.raw(0, 0), 1234);  // 0 = 100% confidence
  EXPECT_EQ(d.raw(1, 0), 0);     // 1 = 0% confidence: no measurement
  EXPECT_EQ(d.raw(2, 0), 8191);
  EXPECT_DOUBLE_EQ(d.metres(0, 0), 1.234);
  EXPECT_DOUBLE_EQ(d.metres(3, 0), 0.001);
}

TEST(ImageView, ColourFormatsAndStridesGiveTheSameRgba) {
  const std::vector<std::uint8_t> rgb{10, 20, 30, 40, 50, 60, 0, 0, 70, 80, 90, 1, 2, 3, 0, 0};
  const std::vector<std::uint8_t> bgra{30, 20, 10, 9, 60, 50, 40, 9, 3, 2, 1, 9, 0, 0, 0, 0};
  const ColorView a{rgb.data(), 2, 2, 8, ColorFormat::kRgb8, rgb.size()};
  const ColorView b{bgra.data(), 1, 2, 8, ColorFormat::kBgra8, 0};
  EXPECT_EQ(a.rgba(1, 0), 0xFF3C3228u);  // 40, 50, 60
  EXPECT_EQ(a.rgba(0, 1), 0xFF5A5046u);  // 70, 80, 90
  EXPECT_EQ(b.rgba(0, 0), 0xFF1E140Au);  // 10, 20, 30
  EXPECT_EQ(b.rgba(0, 1), 0xFF030201u);  // 1, 2, 3: the second row, 8 bytes on
}

TEST(ImageView, ChecksNameActualAndExpectedValues) {
  const auto message = [](const Status& s) { return s.ok() ? std::string() : s.error().message; };
  std::vector<std::uint16_t> raw(40);
  EXPECT_EQ(message(DepthView::uint16(raw.data(), 8, 5, 1000.0, 14).check(8, 5)),
            "depth frame row stride is 14 bytes, expected a multiple of 2 of at least 16 (8 "
            "pixels)");
  EXPECT_EQ(message(DepthView::uint16(raw.data(), 8, 5, 1000.0, 17).check(8, 5)),
            "depth frame row stride is 17 bytes, expected a multiple of 2 of at least 16 (8 "
            "pixels)");
  EXPECT_EQ(message(DepthView::metres(nullptr, 8, 5).check(8, 5)),
            "depth frame has a null data pointer");
  EXPECT_EQ(message(DepthView::uint16(raw.data(), 8, 5, 0.0).check(8, 5)),
            "depth_scale must be positive, got 0.000000");
  EXPECT_EQ(message(DepthView::uint16(raw.data(), 8, 5, 1000.0).check(8, 6)),
            "depth frame is 8x5, expected 8x6");
  DepthImage image{8, 5, 1000.0, std::vector<std::uint16_t>(39)};
  EXPECT_EQ(message(image.view().check(8, 5)),
            "depth frame buffer holds 78 bytes, 8x5 at a row stride of 16 bytes needs 80");
  image.data.resize(40);
  EXPECT_TRUE(image.view().check(8, 5).ok());
  ColorImage colour{8, 5, std::vector<std::uint8_t>(119)};
  EXPECT_EQ(message(colour.view().check(8, 5)),
            "colour frame buffer holds 119 bytes, 8x5 at a row stride of 24 bytes needs 120");
  EXPECT_EQ(ColorInput(nullptr).get(), nullptr);
  EXPECT_EQ(ColorInput(static_cast<const ColorImage*>(nullptr)).get(), nullptr);
  ASSERT_NE(ColorInput(&colour).get(), nullptr);
  EXPECT_EQ(ColorInput(&colour).get()->data, colour.data.data());
}

}  // namespace
}  // namespace imufusion

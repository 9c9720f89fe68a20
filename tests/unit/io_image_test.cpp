#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "imufusion/image_io.hpp"
#include "io/png_codec.hpp"
#include "io_test_fixtures.hpp"

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

namespace imufusion {
namespace {

using testing::TempDir;

bool mentions(const Error& error, const std::filesystem::path& path) {
  return error.message.find(path.string()) != std::string::npos;
}

std::size_t count_temp_files(const std::filesystem::path& dir) {
  return static_cast<std::size_t>(
      std::count_if(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator(),
                    [](const auto& entry) {
                      return entry.path().filename().string().find(".tmp-") != std::string::npos;
                    }));
}

TEST(DepthPng, RoundTripIsBitExactAtOddSize) {
  TempDir dir;
  const DepthImage written = testing::make_depth(97, 61, 7);
  ASSERT_TRUE(write_depth_png(dir / "d.png", written).ok());
  auto read = read_depth_png(dir / "d.png", 1000.0);
  ASSERT_TRUE(read.ok()) << read.error().describe();
  EXPECT_EQ(read->width, 97);
  EXPECT_EQ(read->height, 61);
  EXPECT_EQ(read->depth_scale, 1000.0);
  EXPECT_EQ(read->data, written.data);
  EXPECT_EQ(count_temp_files(dir.path()), 0u);
}

TEST(DepthPng, ReadsBigEndianSamplesOfAnotherEncoder) {
  TempDir dir;
  const std::vector<std::uint16_t> values = {0x0102, 0xFF00, 0x00FF, 5000, 0, 65535};
  std::vector<std::uint8_t> big_endian;
  for (std::uint16_t value : values) {
    big_endian.insert(big_endian.end(), {std::uint8_t(value >> 8), std::uint8_t(value & 0xFF)});
  }
  testing::write_png_independently(dir / "other.png", 3, 2, 16, 0, big_endian);
  auto read = read_depth_png(dir / "other.png", 5000.0);
  ASSERT_TRUE(read.ok()) << read.error().describe();
  EXPECT_EQ(read->data, values);
  EXPECT_EQ(read->at(0, 0), 0x0102);
  EXPECT_EQ(read->at(2, 1), 65535);
}

TEST(DepthPng, ReadsInterlacedFiles) {
  TempDir dir;
  const DepthImage image = testing::make_depth(13, 11, 21);
  std::vector<std::uint8_t> big_endian;
  for (std::uint16_t value : image.data) {
    big_endian.insert(big_endian.end(), {std::uint8_t(value >> 8), std::uint8_t(value & 0xFF)});
  }
  testing::write_png_independently(dir / "adam7.png", 13, 11, 16, 0, big_endian, true);
  auto read = read_depth_png(dir / "adam7.png", 5000.0);
  ASSERT_TRUE(read.ok()) << read.error().describe();
  EXPECT_EQ(read->data, image.data);

  const ColorImage color = testing::make_color(13, 11, 22);
  testing::write_png_independently(dir / "adam7_rgb.png", 13, 11, 8, 2, color.data, true);
  auto read_color = read_color_image(dir / "adam7_rgb.png");
  ASSERT_TRUE(read_color.ok()) << read_color.error().describe();
  EXPECT_EQ(read_color->data, color.data);
}

TEST(DepthPng, MissingFileIsNotFound) {
  TempDir dir;
  auto read = read_depth_png(dir / "absent.png", 5000.0);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, ErrorCode::kNotFound);
  EXPECT_TRUE(mentions(read.error(), dir / "absent.png")) << read.error().message;
}

TEST(DepthPng, TruncatedFileFailsAtEveryCut) {
  TempDir dir;
  ASSERT_TRUE(write_depth_png(dir / "full.png", testing::make_depth(40, 30, 3)).ok());
  const std::vector<char> bytes = testing::read_bytes(dir / "full.png");
  ASSERT_GT(bytes.size(), 100u);
  // Cuts inside the signature, the IHDR, the image data and just before the IEND chunk.
  for (std::size_t cut : {std::size_t{4}, std::size_t{20}, std::size_t{40}, bytes.size() / 2,
                          bytes.size() - 12, bytes.size() - 1}) {
    std::vector<char> truncated(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(cut));
    const auto path = dir / ("cut_" + std::to_string(cut) + ".png");
    testing::write_bytes(path, truncated);
    auto read = read_depth_png(path, 5000.0);
    ASSERT_FALSE(read.ok()) << "cut at " << cut;
    EXPECT_EQ(read.error().code, ErrorCode::kParseError) << read.error().message;
    EXPECT_TRUE(mentions(read.error(), path)) << read.error().message;
  }
}

TEST(DepthPng, CorruptImageDataFails) {
  TempDir dir;
  ASSERT_TRUE(write_depth_png(dir / "full.png", testing::make_depth(40, 30, 4)).ok());
  std::vector<char> bytes = testing::read_bytes(dir / "full.png");
  for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 16; ++i) bytes[i] ^= 0x5A;
  testing::write_bytes(dir / "corrupt.png", bytes);
  auto read = read_depth_png(dir / "corrupt.png", 5000.0);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, ErrorCode::kParseError);
  EXPECT_TRUE(mentions(read.error(), dir / "corrupt.png")) << read.error().message;
}

TEST(DepthPng, NonPngFileFails) {
  TempDir dir;
  testing::write_text(dir / "text.png", "this is not an image\n");
  auto read = read_depth_png(dir / "text.png", 5000.0);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, ErrorCode::kParseError);
  EXPECT_NE(read.error().message.find("not a PNG"), std::string::npos) << read.error().message;
  EXPECT_TRUE(mentions(read.error(), dir / "text.png"));
}

TEST(DepthPng, EightBitGrayIsWrongBitDepth) {
  TempDir dir;
  const std::vector<std::uint8_t> pixels(6 * 4, 17);
  testing::write_png_independently(dir / "gray8.png", 6, 4, 8, 0, pixels);
  auto read = read_depth_png(dir / "gray8.png", 5000.0);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(read.error().message.find("wrong bit depth 8"), std::string::npos)
      << read.error().message;
  EXPECT_TRUE(mentions(read.error(), dir / "gray8.png"));
}

TEST(DepthPng, ColourPngIsNotSingleChannel) {
  TempDir dir;
  ASSERT_TRUE(write_color_png(dir / "rgb.png", testing::make_color(5, 5, 1)).ok());
  auto read = read_depth_png(dir / "rgb.png", 5000.0);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(read.error().message.find("not single-channel"), std::string::npos)
      << read.error().message;
  EXPECT_TRUE(mentions(read.error(), dir / "rgb.png"));
}

TEST(DepthPng, RejectsNonPositiveDepthScale) {
  TempDir dir;
  ASSERT_TRUE(write_depth_png(dir / "d.png", testing::make_depth(4, 4, 1)).ok());
  EXPECT_EQ(read_depth_png(dir / "d.png", 0.0).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(read_depth_png(dir / "d.png", -5.0).error().code, ErrorCode::kInvalidArgument);
}

TEST(DepthPng, RejectsImageWhoseDataDoesNotMatchItsSize) {
  TempDir dir;
  DepthImage image = testing::make_depth(4, 4, 1);
  image.data.pop_back();
  auto status = write_depth_png(dir / "d.png", image);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kInvalidArgument);
  EXPECT_FALSE(std::filesystem::exists(dir / "d.png"));
}

TEST(DepthPng, AHeaderDeclaringMoreThanTheFileCanHoldIsRefusedUnallocated) {
  // png_fuzz: a file of about 70 bytes declaring 10000x10000 pixels had 200 MB allocated for them
  // before libpng found the data missing. DEFLATE expands 1032:1 at most.
  std::vector<char> png =
      testing::encode_png_independently(2, 2, 16, 0, std::vector<std::uint8_t>(8));
  const std::uint8_t size[8] = {0, 0, 0x27, 0x10, 0, 0, 0x27, 0x10};  // 10000 x 10000, big-endian
  std::copy(size, size + 8, png.begin() + 16);
  std::uint32_t crc = 0xFFFFFFFFu;  // the IHDR chunk's CRC over its type and data (bytes 12..28)
  for (int i = 12; i < 29; ++i) {
    crc ^= static_cast<std::uint8_t>(png[i]);
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  crc ^= 0xFFFFFFFFu;
  for (int b = 0; b < 4; ++b) png[29 + b] = static_cast<char>(crc >> (24 - 8 * b));
  const std::vector<std::uint8_t> bytes(png.begin(), png.end());
  auto depth = io::decode_depth_png(bytes, "claims.png", 1000.0);
  ASSERT_FALSE(depth.ok());
  EXPECT_EQ(depth.error().code, ErrorCode::kParseError);
  EXPECT_NE(depth.error().message.find("cannot hold the 10000x10000 image"), std::string::npos)
      << depth.error().message;
  auto color = io::decode_color_png(bytes, "claims.png");
  ASSERT_FALSE(color.ok());
  EXPECT_NE(color.error().message.find("cannot hold"), std::string::npos) << color.error().message;
}

TEST(AtomicWrite, FailedWriteKeepsExistingFile) {
  TempDir dir;
  const DepthImage original = testing::make_depth(8, 8, 11);
  ASSERT_TRUE(write_depth_png(dir / "d.png", original).ok());
  DepthImage broken = testing::make_depth(8, 8, 12);
  broken.width = 9;  // data no longer matches the size
  ASSERT_FALSE(write_depth_png(dir / "d.png", broken).ok());
  auto read = read_depth_png(dir / "d.png", 5000.0);
  ASSERT_TRUE(read.ok());
  EXPECT_EQ(read->data, original.data);
  EXPECT_EQ(count_temp_files(dir.path()), 0u);
}

TEST(AtomicWrite, MissingDirectoryFailsNamingThePath) {
  TempDir dir;
  const auto path = dir / "no_such_dir" / "d.png";
  auto status = write_depth_png(path, testing::make_depth(8, 8, 1));
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kIoError);
  EXPECT_TRUE(mentions(status.error(), path)) << status.error().message;
  EXPECT_FALSE(std::filesystem::exists(dir / "no_such_dir"));
}

TEST(AtomicWrite, FailedRenameRemovesTemporaryAndKeepsTarget) {
  TempDir dir;
  // The target is a non-empty directory: the rename over it fails after the PNG was encoded.
  std::filesystem::create_directories(dir / "target.png");
  testing::write_text(dir / "target.png" / "keep.txt", "keep");
  auto status = write_color_png(dir / "target.png", testing::make_color(8, 8, 2));
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kIoError);
  EXPECT_TRUE(std::filesystem::exists(dir / "target.png" / "keep.txt"));
  EXPECT_EQ(count_temp_files(dir.path()), 0u);
}

TEST(AtomicWrite, ReplacesExistingFile) {
  TempDir dir;
  ASSERT_TRUE(write_depth_png(dir / "d.png", testing::make_depth(8, 8, 1)).ok());
  const DepthImage second = testing::make_depth(5, 3, 2);
  ASSERT_TRUE(write_depth_png(dir / "d.png", second).ok());
  auto read = read_depth_png(dir / "d.png", 5000.0);
  ASSERT_TRUE(read.ok());
  EXPECT_EQ(read->data, second.data);
}

TEST(ColorImage, PngRoundTripAtOddSize) {
  TempDir dir;
  const ColorImage written = testing::make_color(97, 61, 5);
  ASSERT_TRUE(write_color_png(dir / "c.png", written).ok());
  auto read = read_color_image(dir / "c.png");
  ASSERT_TRUE(read.ok()) << read.error().describe();
  EXPECT_EQ(read->width, 97);
  EXPECT_EQ(read->height, 61);
  EXPECT_EQ(read->data, written.data);
}

TEST(ColorImage, GrayPngIsExpandedToRgb) {
  TempDir dir;
  const std::vector<std::uint8_t> pixels = {0, 50, 100, 150, 200, 250};
  testing::write_png_independently(dir / "g.png", 3, 2, 8, 0, pixels);
  auto read = read_color_image(dir / "g.png");
  ASSERT_TRUE(read.ok()) << read.error().describe();
  ASSERT_EQ(read->data.size(), 18u);
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    EXPECT_EQ(read->data[3 * i], pixels[i]);
    EXPECT_EQ(read->data[3 * i + 1], pixels[i]);
    EXPECT_EQ(read->data[3 * i + 2], pixels[i]);
  }
}

TEST(ColorImage, RgbaPngDropsAlpha) {
  TempDir dir;
  const std::vector<std::uint8_t> pixels = {10, 20, 30, 255, 40, 50, 60, 255};
  testing::write_png_independently(dir / "a.png", 2, 1, 8, 6, pixels);
  auto read = read_color_image(dir / "a.png");
  ASSERT_TRUE(read.ok()) << read.error().describe();
  EXPECT_EQ(read->data, (std::vector<std::uint8_t>{10, 20, 30, 40, 50, 60}));
}

TEST(ColorImage, SixteenBitRgbPngKeepsTheHighByte) {
  TempDir dir;
  const std::vector<std::uint8_t> samples = {0x12, 0x34, 0xAB, 0xCD, 0xFF, 0x00};
  testing::write_png_independently(dir / "c16.png", 1, 1, 16, 2, samples);
  auto read = read_color_image(dir / "c16.png");
  ASSERT_TRUE(read.ok()) << read.error().describe();
  EXPECT_EQ(read->data, (std::vector<std::uint8_t>{0x12, 0xAB, 0xFF}));
}

TEST(ColorImage, ReadsJpeg) {
  TempDir dir;
  // A flat colour survives JPEG compression within a few levels.
  ColorImage flat;
  flat.width = 33;
  flat.height = 17;
  for (int i = 0; i < flat.width * flat.height; ++i) {
    flat.data.insert(flat.data.end(), {200, 100, 50});
  }
  const auto path = dir / "c.jpg";
  ASSERT_NE(stbi_write_jpg(path.c_str(), flat.width, flat.height, 3, flat.data.data(), 95), 0);
  auto read = read_color_image(path);
  ASSERT_TRUE(read.ok()) << read.error().describe();
  EXPECT_EQ(read->width, 33);
  EXPECT_EQ(read->height, 17);
  for (std::size_t i = 0; i < flat.data.size(); ++i) {
    ASSERT_NEAR(read->data[i], flat.data[i], 4) << "byte " << i;
  }
}

TEST(ColorImage, CorruptJpegFailsNamingTheFile) {
  TempDir dir;
  testing::write_bytes(dir / "bad.jpg",
                       {'\xFF', '\xD8', '\xFF', 'g', 'a', 'r', 'b', 'a', 'g', 'e'});
  auto read = read_color_image(dir / "bad.jpg");
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, ErrorCode::kParseError);
  EXPECT_TRUE(mentions(read.error(), dir / "bad.jpg")) << read.error().message;
}

TEST(ColorImage, UnknownFormatFails) {
  TempDir dir;
  testing::write_text(dir / "c.png", "GIF89a....");
  auto read = read_color_image(dir / "c.png");
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, ErrorCode::kParseError);
  EXPECT_TRUE(mentions(read.error(), dir / "c.png"));
}

TEST(ColorImage, TruncatedPngFails) {
  TempDir dir;
  ASSERT_TRUE(write_color_png(dir / "c.png", testing::make_color(30, 20, 9)).ok());
  std::vector<char> bytes = testing::read_bytes(dir / "c.png");
  bytes.resize(bytes.size() / 2);
  testing::write_bytes(dir / "c.png", bytes);
  auto read = read_color_image(dir / "c.png");
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, ErrorCode::kParseError);
  EXPECT_TRUE(mentions(read.error(), dir / "c.png"));
}

}  // namespace
}  // namespace imufusion

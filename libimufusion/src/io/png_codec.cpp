#include "io/png_codec.hpp"

#include <png.h>

#include <bit>
#include <csetjmp>
#include <cstring>
#include <string>

#include "io/atomic_file.hpp"

namespace imufusion::io {
namespace {

// Larger images are refused before allocation: a corrupt header must not request gigabytes.
constexpr std::int64_t kMaxPixels = std::int64_t{1} << 27;
// DEFLATE expands at most 1032:1 (a 258-byte match in two bits): a file of N bytes holds at most
// 1032 N bytes of image data, and a header declaring more is corrupt.
constexpr std::uint64_t kMaxDeflateRatio = 1032;

constexpr std::uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

// Plain C data shared with libpng's callbacks (error_ptr / io_ptr).
struct PngCallbackState {
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
  std::size_t offset = 0;
  char message[256] = {};
};

[[noreturn]] void on_png_error(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngCallbackState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof(state->message), "%s", message);
  png_longjmp(png, 1);
}

// Warnings (an unknown ancillary chunk, a questionable iCCP profile) do not affect the pixels.
void on_png_warning(png_structp, png_const_charp) {}

void read_from_memory(png_structp png, png_bytep out, png_size_t length) {
  auto* state = static_cast<PngCallbackState*>(png_get_io_ptr(png));
  if (length > state->size - state->offset) png_error(png, "unexpected end of file (truncated)");
  std::memcpy(out, state->data + state->offset, length);
  state->offset += length;
}

const char* color_type_name(int color_type) {
  switch (color_type) {
    case PNG_COLOR_TYPE_GRAY:
      return "grayscale";
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      return "grayscale+alpha";
    case PNG_COLOR_TYPE_PALETTE:
      return "palette";
    case PNG_COLOR_TYPE_RGB:
      return "RGB";
    case PNG_COLOR_TYPE_RGB_ALPHA:
      return "RGBA";
    default:
      return "unknown";
  }
}

// The setjmp-protected steps. Each returns false after a libpng error (message in the state).
// Nothing in these frames has a destructor, and no local is modified after setjmp.

bool png_read_header_step(png_structp png, png_infop info, png_uint_32* width, png_uint_32* height,
                          int* bit_depth, int* color_type) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  png_get_IHDR(png, info, width, height, bit_depth, color_type, nullptr, nullptr, nullptr);
  return true;
}

bool png_setup_depth_step(png_structp png, png_infop info) {
  if (setjmp(png_jmpbuf(png))) return false;
  // PNG stores 16-bit samples big-endian; swap on little-endian hosts.
  if constexpr (std::endian::native == std::endian::little) png_set_swap(png);
  png_set_interlace_handling(png);  // Adam7 files are de-interlaced by png_read_image
  png_read_update_info(png, info);
  return true;
}

bool png_setup_color_step(png_structp png, png_infop info, int bit_depth, int color_type) {
  if (setjmp(png_jmpbuf(png))) return false;
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (color_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (bit_depth == 16) png_set_strip_16(png);
  if (color_type & PNG_COLOR_MASK_ALPHA) png_set_strip_alpha(png);
  if (color_type == PNG_COLOR_TYPE_GRAY || color_type == PNG_COLOR_TYPE_GRAY_ALPHA) {
    png_set_gray_to_rgb(png);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  return true;
}

bool png_read_rows_step(png_structp png, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_image(png, rows);
  png_read_end(png, nullptr);
  return true;
}

bool png_write_step(png_structp png, png_infop info, std::FILE* file, png_uint_32 width,
                    png_uint_32 height, int bit_depth, int color_type, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_init_io(png, file);
  // Live recording writes every frame as it arrives: favour speed over file size.
  png_set_compression_level(png, 1);
  png_set_IHDR(png, info, width, height, bit_depth, color_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (bit_depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  return true;
}

// Owns the libpng read structures for one decode.
class PngReader {
 public:
  PngReader(const std::vector<std::uint8_t>& bytes) {
    state_.data = bytes.data();
    state_.size = bytes.size();
    png_ = png_create_read_struct(PNG_LIBPNG_VER_STRING, &state_, on_png_error, on_png_warning);
    if (png_ != nullptr) info_ = png_create_info_struct(png_);
    if (info_ != nullptr) png_set_read_fn(png_, &state_, read_from_memory);
  }
  ~PngReader() { png_destroy_read_struct(&png_, info_ != nullptr ? &info_ : nullptr, nullptr); }
  PngReader(const PngReader&) = delete;
  PngReader& operator=(const PngReader&) = delete;

  bool valid() const { return info_ != nullptr; }
  std::size_t file_size() const { return state_.size; }
  png_structp png() { return png_; }
  png_infop info() { return info_; }
  std::string message() const { return state_.message; }

 private:
  PngCallbackState state_;
  png_structp png_ = nullptr;
  png_infop info_ = nullptr;
};

Error corrupt(const std::filesystem::path& path, const PngReader& reader) {
  return make_error(ErrorCode::kParseError,
                    path.string() + ": corrupt or truncated PNG (" + reader.message() + ")");
}

Status check_size(const std::filesystem::path& path, png_uint_32 width, png_uint_32 height) {
  if (width == 0 || height == 0 ||
      static_cast<std::int64_t>(width) * static_cast<std::int64_t>(height) > kMaxPixels) {
    return make_error(ErrorCode::kUnsupported, path.string() + ": image size " +
                                                   std::to_string(width) + "x" +
                                                   std::to_string(height) + " is not supported");
  }
  return {};
}

Result<PngHeader> decode_header(PngReader& reader, const std::filesystem::path& path) {
  if (!reader.valid()) {
    return make_error(ErrorCode::kInternal, path.string() + ": cannot initialise libpng");
  }
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, color_type = 0;
  if (!png_read_header_step(reader.png(), reader.info(), &width, &height, &bit_depth,
                            &color_type)) {
    return corrupt(path, reader);
  }
  IMUFUSION_RETURN_IF_ERROR(check_size(path, width, height));
  // Checked before the image is allocated: a 60-byte file must not claim 10000x10000 pixels.
  const std::uint64_t data_bytes =
      std::uint64_t{png_get_rowbytes(reader.png(), reader.info())} * height;
  if (data_bytes > kMaxDeflateRatio * reader.file_size()) {
    return make_error(ErrorCode::kParseError,
                      path.string() + ": corrupt or truncated PNG (its " +
                          std::to_string(reader.file_size()) + " bytes cannot hold the " +
                          std::to_string(width) + "x" + std::to_string(height) +
                          " image its header declares)");
  }
  return PngHeader{static_cast<int>(width), static_cast<int>(height), bit_depth, color_type};
}

Error not_png(const std::filesystem::path& path) {
  return make_error(ErrorCode::kParseError, path.string() + ": not a PNG file (bad signature)");
}

}  // namespace

bool has_png_signature(const std::vector<std::uint8_t>& bytes) {
  return bytes.size() >= sizeof(kPngSignature) &&
         std::memcmp(bytes.data(), kPngSignature, sizeof(kPngSignature)) == 0;
}

Result<PngHeader> read_png_header(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return make_error(ErrorCode::kNotFound, path.string() + ": no such file");
  }
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) {
    return make_error(ErrorCode::kIoError,
                      "cannot open " + path.string() + ": " + std::strerror(errno));
  }
  // Signature (8) + chunk length (4) + "IHDR" (4) + width (4) + height (4) + depth (1) + type (1).
  std::vector<std::uint8_t> bytes(26);
  const std::size_t n = std::fread(bytes.data(), 1, bytes.size(), file);
  std::fclose(file);
  bytes.resize(n);
  if (!has_png_signature(bytes)) return not_png(path);
  if (n < 26 || std::memcmp(bytes.data() + 12, "IHDR", 4) != 0) {
    return make_error(ErrorCode::kParseError,
                      path.string() + ": corrupt or truncated PNG (no IHDR chunk)");
  }
  auto be32 = [&](std::size_t at) {
    return (png_uint_32{bytes[at]} << 24) | (png_uint_32{bytes[at + 1]} << 16) |
           (png_uint_32{bytes[at + 2]} << 8) | png_uint_32{bytes[at + 3]};
  };
  const png_uint_32 width = be32(16), height = be32(20);
  IMUFUSION_RETURN_IF_ERROR(check_size(path, width, height));
  return PngHeader{static_cast<int>(width), static_cast<int>(height), bytes[24], bytes[25]};
}

Result<DepthImage> decode_depth_png(const std::vector<std::uint8_t>& bytes,
                                    const std::filesystem::path& path, double depth_scale) {
  if (!has_png_signature(bytes)) return not_png(path);
  PngReader reader(bytes);
  auto header = decode_header(reader, path);
  if (!header.ok()) return header.error();
  if (header->color_type != PNG_COLOR_TYPE_GRAY) {
    return make_error(ErrorCode::kUnsupported, path.string() + ": not single-channel (" +
                                                   color_type_name(header->color_type) +
                                                   "); a depth image must be 16-bit grayscale");
  }
  if (header->bit_depth != 16) {
    return make_error(ErrorCode::kUnsupported, path.string() + ": wrong bit depth " +
                                                   std::to_string(header->bit_depth) +
                                                   " (a depth image must be 16-bit grayscale)");
  }
  if (!png_setup_depth_step(reader.png(), reader.info())) return corrupt(path, reader);
  DepthImage image;
  image.width = header->width;
  image.height = header->height;
  image.depth_scale = depth_scale;
  image.data.resize(static_cast<std::size_t>(image.width) * image.height);
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.height));
  for (int v = 0; v < image.height; ++v) {
    rows[v] =
        reinterpret_cast<png_bytep>(image.data.data() + static_cast<std::size_t>(v) * image.width);
  }
  if (!png_read_rows_step(reader.png(), rows.data())) return corrupt(path, reader);
  return image;
}

Result<ColorImage> decode_color_png(const std::vector<std::uint8_t>& bytes,
                                    const std::filesystem::path& path) {
  if (!has_png_signature(bytes)) return not_png(path);
  PngReader reader(bytes);
  auto header = decode_header(reader, path);
  if (!header.ok()) return header.error();
  if (!png_setup_color_step(reader.png(), reader.info(), header->bit_depth, header->color_type)) {
    return corrupt(path, reader);
  }
  const std::size_t row_bytes = static_cast<std::size_t>(header->width) * 3;
  if (png_get_channels(reader.png(), reader.info()) != 3 ||
      png_get_rowbytes(reader.png(), reader.info()) != row_bytes) {
    return make_error(ErrorCode::kUnsupported,
                      path.string() + ": cannot convert " + color_type_name(header->color_type) +
                          " " + std::to_string(header->bit_depth) + "-bit PNG to 8-bit RGB");
  }
  ColorImage image;
  image.width = header->width;
  image.height = header->height;
  image.data.resize(row_bytes * static_cast<std::size_t>(image.height));
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.height));
  for (int v = 0; v < image.height; ++v) rows[v] = image.data.data() + v * row_bytes;
  if (!png_read_rows_step(reader.png(), rows.data())) return corrupt(path, reader);
  return image;
}

Status encode_png(std::FILE* file, const std::filesystem::path& path, int width, int height,
                  int channels, const void* pixels) {
  const int bit_depth = channels == 1 ? 16 : 8;
  const int color_type = channels == 1 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB;
  const std::size_t row_bytes = static_cast<std::size_t>(width) * channels * (bit_depth / 8);
  // libpng copies each row before transforming it, so the caller's pixels are never written.
  auto* base = static_cast<png_bytep>(const_cast<void*>(pixels));
  std::vector<png_bytep> rows(static_cast<std::size_t>(height));
  for (int v = 0; v < height; ++v) rows[v] = base + v * row_bytes;

  PngCallbackState state;
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &state, on_png_error, on_png_warning);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return make_error(ErrorCode::kInternal, path.string() + ": cannot initialise libpng");
  }
  const bool written =
      png_write_step(png, info, file, static_cast<png_uint_32>(width),
                     static_cast<png_uint_32>(height), bit_depth, color_type, rows.data());
  png_destroy_write_struct(&png, &info);
  if (!written) {
    return make_error(ErrorCode::kIoError,
                      "cannot write PNG " + path.string() + " (" + state.message + ")");
  }
  return {};
}

}  // namespace imufusion::io

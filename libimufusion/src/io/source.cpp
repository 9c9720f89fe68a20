// open_frame_source(): dispatch on the input's form, and the sequence-directory source.

#include "imufusion/source.hpp"

#include <cctype>
#include <charconv>
#include <filesystem>

#include "io/frame_pacer.hpp"
#include "io/openni2_source.hpp"

namespace imufusion {
namespace {

constexpr std::string_view kOpenNI2Scheme = "openni2://";

bool ends_with_oni(std::string_view input) {
  if (input.size() < 4) return false;
  std::string tail(input.substr(input.size() - 4));
  for (char& c : tail) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return tail == ".oni";
}

class SequenceSource final : public FrameSource {
 public:
  SequenceSource(SequenceReader reader, bool realtime)
      : reader_(std::move(reader)), realtime_(realtime) {
    intrinsics_ = *reader_.intrinsics();
    intrinsics_.width = reader_.info().width;
    intrinsics_.height = reader_.info().height;
  }

  Result<std::optional<Frame>> next() override {
    if (reader_.done()) return std::optional<Frame>();
    auto frame = reader_.next();
    if (!frame.ok()) return frame.error();
    if (realtime_) pacer_.wait_for(frame->timestamp);
    return std::optional<Frame>(std::move(frame).value());
  }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  bool live() const override { return false; }
  std::string description() const override {
    return "sequence " + reader_.info().directory.string();
  }
  std::optional<Eigen::Isometry3d> T_camera_imu() const override {
    if (!reader_.info().has_imu_to_camera) return std::nullopt;
    return reader_.T_camera_imu();
  }

 private:
  SequenceReader reader_;
  bool realtime_;
  Intrinsics intrinsics_;
  io::FramePacer pacer_;
};

Result<int> parse_positive(std::string_view text, std::string_view whole, const char* what) {
  int value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || value <= 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      "depth mode '" + std::string(whole) + "': " + what +
                          " is not a positive integer (expected WxH@FPS, e.g. 640x480@30)");
  }
  return value;
}

}  // namespace

Result<DepthMode> parse_depth_mode(std::string_view text) {
  const std::size_t x = text.find('x');
  const std::size_t at = text.find('@');
  if (x == std::string_view::npos || at == std::string_view::npos || at < x) {
    return make_error(ErrorCode::kInvalidArgument,
                      "depth mode '" + std::string(text) + "' is not WxH@FPS (e.g. 640x480@30)");
  }
  auto width = parse_positive(text.substr(0, x), text, "width");
  if (!width.ok()) return width.error();
  auto height = parse_positive(text.substr(x + 1, at - x - 1), text, "height");
  if (!height.ok()) return height.error();
  auto fps = parse_positive(text.substr(at + 1), text, "frame rate");
  if (!fps.ok()) return fps.error();
  return DepthMode{*width, *height, *fps};
}

Result<std::unique_ptr<FrameSource>> open_frame_source(std::string_view input,
                                                       const SourceOptions& options) {
  if (input.substr(0, kOpenNI2Scheme.size()) == kOpenNI2Scheme) {
    return io::open_openni2_source(input.substr(kOpenNI2Scheme.size()), false, options);
  }
  if (input.find("://") != std::string_view::npos) {
    return make_error(ErrorCode::kInvalidArgument,
                      "input '" + std::string(input) +
                          "': unknown scheme (expected openni2://, FILE.oni or a sequence "
                          "directory)");
  }
  const std::filesystem::path path{std::string(input)};
  if (ends_with_oni(input)) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) {
      return make_error(ErrorCode::kNotFound, path.string() + ": no such recording");
    }
    return io::open_openni2_source(input, true, options);
  }
  SequenceOptions sequence = options.sequence;
  sequence.load_color = sequence.load_color && options.color;
  auto reader = SequenceReader::open(path, sequence);
  if (!reader.ok()) return reader.error();
  if (!reader->intrinsics()) {
    return make_error(ErrorCode::kInvalidArgument,
                      path.string() + ": no calibration.txt and no intrinsics given");
  }
  return std::unique_ptr<FrameSource>(
      std::make_unique<SequenceSource>(std::move(reader).value(), options.realtime));
}

}  // namespace imufusion

// OpenNI2 cameras and .oni recordings (openni2_source.hpp).

#include "io/openni2_source.hpp"

#if IMUFUSION_HAVE_OPENNI2

#include <OpenNI.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <mutex>

#include "imufusion/clock_offset.hpp"
#include "imufusion/imu_stream.hpp"

namespace imufusion {
namespace io {
namespace {

// OpenNI::initialize / shutdown are process-wide; sources share one initialisation.
std::mutex g_openni_mutex;
int g_openni_users = 0;

std::string openni_error() {
  const char* text = openni::OpenNI::getExtendedError();
  std::string message = text != nullptr ? text : "";
  while (!message.empty() && (message.back() == '\n' || message.back() == ' ' ||
                              message.back() == '\t')) {
    message.pop_back();
  }
  // OpenNI prefixes its messages with a tab.
  const std::size_t first = message.find_first_not_of("\t ");
  return first == std::string::npos ? "no detail from OpenNI2" : message.substr(first);
}

Status acquire_openni() {
  std::lock_guard lock(g_openni_mutex);
  if (g_openni_users == 0 && openni::OpenNI::initialize() != openni::STATUS_OK) {
    return make_error(ErrorCode::kNoDevice,
                      "OpenNI2 failed to initialise (drivers missing?): " + openni_error());
  }
  ++g_openni_users;
  return {};
}

void release_openni() {
  std::lock_guard lock(g_openni_mutex);
  if (--g_openni_users == 0) openni::OpenNI::shutdown();
}

std::string describe_mode(const openni::VideoMode& mode) {
  return std::to_string(mode.getResolutionX()) + "x" + std::to_string(mode.getResolutionY()) +
         "@" + std::to_string(mode.getFps());
}

// Raw depth units per metre of an OpenNI2 depth pixel format; 0 for a format that is not depth.
double depth_scale_of(openni::PixelFormat format) {
  switch (format) {
    case openni::PIXEL_FORMAT_DEPTH_1_MM:
      return 1000.0;
    case openni::PIXEL_FORMAT_DEPTH_100_UM:
      return 10000.0;
    default:
      return 0.0;
  }
}

class DisconnectWatch final : public openni::OpenNI::DeviceDisconnectedListener {
 public:
  explicit DisconnectWatch(std::string uri) : uri_(std::move(uri)) {}
  void onDeviceDisconnected(const openni::DeviceInfo* info) override {
    if (info != nullptr && uri_ == info->getUri()) lost_ = true;
  }
  bool lost() const { return lost_; }

 private:
  std::string uri_;
  std::atomic<bool> lost_{false};
};

class OpenNI2Source final : public FrameSource {
 public:
  OpenNI2Source(std::string name, bool is_file, const SourceOptions& options)
      : name_(std::move(name)), is_file_(is_file), options_(options) {}

  ~OpenNI2Source() override {
    if (watch_) openni::OpenNI::removeDeviceDisconnectedListener(watch_.get());
    if (color_.isValid()) {
      color_.stop();
      color_.destroy();
    }
    if (depth_.isValid()) {
      depth_.stop();
      depth_.destroy();
    }
    if (device_.isValid()) device_.close();
    if (acquired_) release_openni();
  }

  Status open();

  Result<std::optional<Frame>> next() override;
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  bool live() const override { return !is_file_; }
  std::string description() const override { return description_; }

 private:
  Status choose_depth_mode();
  void open_color();
  Result<bool> wait_for_depth(int timeout_ms);
  void read_color_until(double device_time, Frame* frame);

  std::string name_;  // the input as given: "openni2://URI" or the .oni path
  bool is_file_;
  SourceOptions options_;
  bool acquired_ = false;
  openni::Device device_;
  openni::VideoStream depth_, color_;
  bool has_color_ = false;
  std::unique_ptr<DisconnectWatch> watch_;
  openni::PlaybackControl* playback_ = nullptr;
  int total_frames_ = 0;
  std::size_t delivered_ = 0;
  double last_device_time_ = -1.0;
  double last_host_time_ = -1.0;
  HostClockMapper clock_;
  Intrinsics intrinsics_;
  std::string description_;
};

Status OpenNI2Source::choose_depth_mode() {
  const openni::SensorInfo& info = depth_.getSensorInfo();
  const auto& modes = info.getSupportedVideoModes();
  const DepthMode& want = options_.depth_mode;
  int best = -1;
  std::string available;
  for (int i = 0; i < modes.getSize(); ++i) {
    const openni::VideoMode& mode = modes[i];
    if (depth_scale_of(mode.getPixelFormat()) == 0.0) continue;
    available += (available.empty() ? "" : ", ") + describe_mode(mode);
    if (mode.getResolutionX() == want.width && mode.getResolutionY() == want.height &&
        mode.getFps() == want.fps &&
        (best < 0 || mode.getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_1_MM)) {
      best = i;
    }
  }
  const std::string wanted = std::to_string(want.width) + "x" + std::to_string(want.height) +
                             "@" + std::to_string(want.fps);
  if (best < 0) {
    return make_error(ErrorCode::kUnsupported, name_ + ": the camera has no depth mode " +
                                                   wanted + " (it has: " + available + ")");
  }
  if (depth_.setVideoMode(modes[best]) != openni::STATUS_OK) {
    return make_error(ErrorCode::kIoError,
                      name_ + ": cannot set depth mode " + wanted + ": " + openni_error());
  }
  return {};
}

void OpenNI2Source::open_color() {
  if (!options_.color || !device_.hasSensor(openni::SENSOR_COLOR)) return;
  if (color_.create(device_, openni::SENSOR_COLOR) != openni::STATUS_OK) return;
  if (!is_file_) {
    // Colour at the depth resolution, so that registered pixels line up one to one.
    const auto& modes = color_.getSensorInfo().getSupportedVideoModes();
    bool set = false;
    for (int i = 0; i < modes.getSize() && !set; ++i) {
      const openni::VideoMode& mode = modes[i];
      if (mode.getPixelFormat() == openni::PIXEL_FORMAT_RGB888 &&
          mode.getResolutionX() == options_.depth_mode.width &&
          mode.getResolutionY() == options_.depth_mode.height &&
          mode.getFps() == options_.depth_mode.fps) {
        set = color_.setVideoMode(mode) == openni::STATUS_OK;
      }
    }
    if (!set) {
      color_.destroy();
      return;
    }
    if (device_.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR)) {
      device_.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR);
    }
    device_.setDepthColorSyncEnabled(true);
  }
  const openni::VideoMode mode = color_.getVideoMode();
  if (mode.getPixelFormat() != openni::PIXEL_FORMAT_RGB888 ||
      mode.getResolutionX() != intrinsics_.width || mode.getResolutionY() != intrinsics_.height ||
      color_.start() != openni::STATUS_OK) {
    color_.destroy();  // a colour stream a Frame cannot carry: depth only
    return;
  }
  has_color_ = true;
}

Status OpenNI2Source::open() {
  IMUFUSION_RETURN_IF_ERROR(acquire_openni());
  acquired_ = true;
  const std::string uri =
      is_file_ ? name_ : name_.substr(std::string_view("openni2://").size());
  if (!is_file_ && uri.empty()) {
    openni::Array<openni::DeviceInfo> devices;
    openni::OpenNI::enumerateDevices(&devices);
    if (devices.getSize() == 0) {
      return make_error(ErrorCode::kNoDevice,
                        name_ + ": no OpenNI2 camera found (is it plugged in, and is its "
                                "driver installed, e.g. PS1080 for Kinect v1 / Xtion?)");
    }
  }
  if (device_.open(uri.empty() ? openni::ANY_DEVICE : uri.c_str()) != openni::STATUS_OK) {
    if (is_file_) {
      return make_error(ErrorCode::kParseError,
                        name_ + ": OpenNI2 cannot open the recording: " + openni_error());
    }
    return make_error(ErrorCode::kNoDevice, name_ + ": cannot open the camera: " + openni_error());
  }
  const openni::DeviceInfo& info = device_.getDeviceInfo();
  description_ = is_file_ ? name_
                          : "openni2://" + std::string(info.getUri()) + " (" +
                                info.getVendor() + " " + info.getName() + ")";
  if (!device_.hasSensor(openni::SENSOR_DEPTH) ||
      depth_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
    return make_error(is_file_ ? ErrorCode::kParseError : ErrorCode::kUnsupported,
                      name_ + ": no depth stream: " + openni_error());
  }
  if (is_file_) {
    playback_ = device_.getPlaybackControl();
    if (playback_ == nullptr) {
      return make_error(ErrorCode::kParseError, name_ + ": not a playable OpenNI2 recording");
    }
    playback_->setRepeatEnabled(false);
    // -1: every frame as soon as it is asked for; 1: the recorded pace.
    playback_->setSpeed(options_.realtime ? 1.0f : -1.0f);
    total_frames_ = playback_->getNumberOfFrames(depth_);
    if (total_frames_ <= 0) {
      return make_error(ErrorCode::kParseError, name_ + ": the recording holds no depth frame");
    }
  } else {
    IMUFUSION_RETURN_IF_ERROR(choose_depth_mode());
    watch_ = std::make_unique<DisconnectWatch>(info.getUri());
    openni::OpenNI::addDeviceDisconnectedListener(watch_.get());
  }
  const openni::VideoMode mode = depth_.getVideoMode();
  if (depth_scale_of(mode.getPixelFormat()) == 0.0) {
    return make_error(ErrorCode::kUnsupported,
                      name_ + ": depth pixel format " + std::to_string(mode.getPixelFormat()) +
                          " is neither 1 mm nor 100 um");
  }
  intrinsics_.width = mode.getResolutionX();
  intrinsics_.height = mode.getResolutionY();
  // OpenNI2 reports the depth camera's fields of view (radians); the principal point is taken
  // at the image centre, as OpenNI2's own depth-to-world conversion does.
  const double hfov = depth_.getHorizontalFieldOfView();
  const double vfov = depth_.getVerticalFieldOfView();
  if (!(hfov > 0.0 && hfov < 3.1) || !(vfov > 0.0 && vfov < 3.1) || intrinsics_.width <= 0 ||
      intrinsics_.height <= 0) {
    return make_error(ErrorCode::kUnsupported,
                      name_ + ": the depth stream reports no usable field of view (" +
                          std::to_string(hfov) + ", " + std::to_string(vfov) + " rad)");
  }
  intrinsics_.fx = 0.5 * intrinsics_.width / std::tan(0.5 * hfov);
  intrinsics_.fy = 0.5 * intrinsics_.height / std::tan(0.5 * vfov);
  intrinsics_.cx = 0.5 * (intrinsics_.width - 1);
  intrinsics_.cy = 0.5 * (intrinsics_.height - 1);
  if (depth_.start() != openni::STATUS_OK) {
    return make_error(is_file_ ? ErrorCode::kParseError : ErrorCode::kIoError,
                      name_ + ": cannot start the depth stream: " + openni_error());
  }
  open_color();
  return {};
}

Result<bool> OpenNI2Source::wait_for_depth(int timeout_ms) {
  openni::VideoStream* streams[] = {&depth_};
  int ready = -1;
  const openni::Status status = openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms);
  if (status == openni::STATUS_OK) return true;
  if (status == openni::STATUS_TIME_OUT) return false;
  return make_error(is_file_ ? ErrorCode::kParseError : ErrorCode::kDeviceLost,
                    name_ + ": waiting for a depth frame failed: " + openni_error());
}

void OpenNI2Source::read_color_until(double device_time, Frame* frame) {
  // Colour frames already there whose stamps do not pass the depth frame's; the last one wins.
  openni::VideoStream* streams[] = {&color_};
  int ready = -1;
  openni::VideoFrameRef ref;
  bool have = false;
  while (openni::OpenNI::waitForAnyStream(streams, 1, &ready, 0) == openni::STATUS_OK) {
    if (color_.readFrame(&ref) != openni::STATUS_OK) break;
    have = true;
    if (static_cast<double>(ref.getTimestamp()) * 1e-6 >= device_time) break;
  }
  if (!have || ref.getWidth() != intrinsics_.width || ref.getHeight() != intrinsics_.height) {
    return;
  }
  ColorImage color;
  color.width = ref.getWidth();
  color.height = ref.getHeight();
  color.data.resize(static_cast<std::size_t>(color.width) * color.height * 3);
  const auto* bytes = static_cast<const std::uint8_t*>(ref.getData());
  const std::size_t row = static_cast<std::size_t>(color.width) * 3;
  for (int v = 0; v < color.height; ++v) {
    std::memcpy(color.data.data() + v * row,
                bytes + static_cast<std::size_t>(v) * ref.getStrideInBytes(), row);
  }
  const double stamp = static_cast<double>(ref.getTimestamp()) * 1e-6;
  frame->color = std::move(color);
  frame->color_timestamp = is_file_ ? stamp : clock_.to_host(stamp);
}

Result<std::optional<Frame>> OpenNI2Source::next() {
  while (true) {
    if (is_file_ && delivered_ >= static_cast<std::size_t>(total_frames_)) {
      return std::optional<Frame>();
    }
    if (watch_ && watch_->lost()) {
      return make_error(ErrorCode::kDeviceLost, description_ + ": camera disconnected");
    }
    const int timeout_ms = static_cast<int>(std::lround(options_.frame_timeout * 1000.0));
    auto ready = wait_for_depth(timeout_ms);
    if (!ready.ok()) return ready.error();
    if (!*ready) {
      if (is_file_) {
        return make_error(ErrorCode::kParseError,
                          name_ + ": no depth frame after frame " + std::to_string(delivered_) +
                              " of " + std::to_string(total_frames_) + " (truncated recording?)");
      }
      return make_error(ErrorCode::kDeviceLost,
                        description_ + ": no depth frame for " +
                            std::to_string(options_.frame_timeout) + " s (camera unplugged?)");
    }
    openni::VideoFrameRef ref;
    if (depth_.readFrame(&ref) != openni::STATUS_OK) {
      return make_error(is_file_ ? ErrorCode::kParseError : ErrorCode::kDeviceLost,
                        name_ + ": reading a depth frame failed: " + openni_error());
    }
    ++delivered_;
    // Device clock, microseconds.
    const double device_time = static_cast<double>(ref.getTimestamp()) * 1e-6;
    const double scale = depth_scale_of(ref.getVideoMode().getPixelFormat());
    if (device_time <= last_device_time_ || scale == 0.0 || ref.getWidth() != intrinsics_.width ||
        ref.getHeight() != intrinsics_.height) {
      continue;  // a repeated stamp or a frame of another mode: not a new frame of this stream
    }
    last_device_time_ = device_time;
    Frame frame;
    frame.index = delivered_ - 1;
    if (is_file_) {
      frame.timestamp = device_time;
    } else {
      // The mapping's offset may drop by more than a frame interval after a delayed first
      // frame; stamps stay strictly increasing (1 us apart at worst) as a Frame requires.
      frame.timestamp = std::max(clock_.observe(host_clock_now(), device_time),
                                 last_host_time_ + 1e-6);
      last_host_time_ = frame.timestamp;
    }
    frame.depth.width = ref.getWidth();
    frame.depth.height = ref.getHeight();
    frame.depth.depth_scale = scale;
    frame.depth.data.resize(static_cast<std::size_t>(frame.depth.width) * frame.depth.height);
    const auto* bytes = static_cast<const std::uint8_t*>(ref.getData());
    const std::size_t row = static_cast<std::size_t>(frame.depth.width) * sizeof(std::uint16_t);
    for (int v = 0; v < frame.depth.height; ++v) {
      std::memcpy(frame.depth.data.data() + static_cast<std::size_t>(v) * frame.depth.width,
                  bytes + static_cast<std::size_t>(v) * ref.getStrideInBytes(), row);
    }
    if (has_color_) read_color_until(device_time, &frame);
    return std::optional<Frame>(std::move(frame));
  }
}

}  // namespace

Result<std::unique_ptr<FrameSource>> open_openni2_source(std::string_view uri, bool is_file,
                                                         const SourceOptions& options) {
  const std::string name = is_file ? std::string(uri) : "openni2://" + std::string(uri);
  auto source = std::make_unique<OpenNI2Source>(name, is_file, options);
  IMUFUSION_RETURN_IF_ERROR(source->open());
  return std::unique_ptr<FrameSource>(std::move(source));
}

}  // namespace io

bool openni2_available() { return true; }

}  // namespace imufusion

#else  // !IMUFUSION_HAVE_OPENNI2

namespace imufusion {
namespace io {

Result<std::unique_ptr<FrameSource>> open_openni2_source(std::string_view uri, bool is_file,
                                                         const SourceOptions&) {
  const std::string name = is_file ? std::string(uri) : "openni2://" + std::string(uri);
  return make_error(ErrorCode::kUnsupported,
                    name + ": this build of imufusion has no OpenNI2 support (install "
                           "libopenni2-dev and reconfigure)");
}

}  // namespace io

bool openni2_available() { return false; }

}  // namespace imufusion

#endif

// OpenNI2 cameras and .oni recordings (openni2_source.hpp).

#include "io/openni2_source.hpp"

#if IMUFUSION_HAVE_OPENNI2

#include <OpenNI.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <mutex>
#include <thread>

#include "imufusion/clock_offset.hpp"
#include "imufusion/imu_stream.hpp"
#include "io/frame_pacer.hpp"

namespace imufusion {
namespace io {
namespace {

// OpenNI::initialize / shutdown are process-wide; sources share one initialisation.
std::mutex g_openni_mutex;
int g_openni_users = 0;

std::string openni_error() {
  const char* text = openni::OpenNI::getExtendedError();
  std::string message = text != nullptr ? text : "";
  while (!message.empty() &&
         (message.back() == '\n' || message.back() == ' ' || message.back() == '\t')) {
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

bool same_mode(const openni::VideoMode& a, const openni::VideoMode& b) {
  return a.getResolutionX() == b.getResolutionX() && a.getResolutionY() == b.getResolutionY() &&
         a.getFps() == b.getFps() && a.getPixelFormat() == b.getPixelFormat();
}

// Sets `mode` unless the stream is in it already (a driver may refuse to set any mode).
bool set_mode(openni::VideoStream& stream, const openni::VideoMode& mode) {
  return same_mode(stream.getVideoMode(), mode) || stream.setVideoMode(mode) == openni::STATUS_OK;
}

std::string describe_mode(const openni::VideoMode& mode) {
  return std::to_string(mode.getResolutionX()) + "x" + std::to_string(mode.getResolutionY()) + "@" +
         std::to_string(mode.getFps());
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
    // OpenNI2's file device walks its list of streams in its playback thread without a lock,
    // continuously while a stream is started (at the end of the file too), every 10 ms once
    // none is. Destroying a stream edits that list: stop all, let that thread see it, then
    // destroy (destroying a started stream crashed about one run in twelve).
    if (color_.isValid()) color_.stop();
    if (depth_.isValid()) depth_.stop();
    if (is_file_) std::this_thread::sleep_for(std::chrono::milliseconds(30));
    if (color_.isValid()) color_.destroy();
    if (depth_.isValid()) depth_.destroy();
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
  Status intrinsics_from_fov();
  Status open_playback();
  Status set_intrinsics(const openni::VideoMode& mode);
  void open_color();
  int timeout_ms() const { return static_cast<int>(std::lround(options_.frame_timeout * 1000.0)); }
  Result<bool> wait_for_depth();
  void read_color_until(double device_time, Frame* frame);
  Result<std::optional<Frame>> next_live();
  // Recordings: frames are read in file order into queues, so that each depth frame can be
  // paired with the colour frame nearest to it whichever of the two the file holds first.
  Result<std::optional<Frame>> next_recorded();
  Result<bool> read_recorded();
  bool color_done() const { return color_frames_ > 0 && color_read_ >= color_frames_; }
  void pair_recorded_color(double device_time, Frame* frame);
  // A depth frame as a Frame (index, timestamp and colour left to the caller); nullopt for a
  // frame that is not a new frame of the stream (a repeated stamp, another mode).
  std::optional<Frame> depth_frame(const openni::VideoFrameRef& ref);

  std::string name_;  // the input as given: "openni2://URI" or the .oni path
  bool is_file_;
  SourceOptions options_;
  bool acquired_ = false;
  openni::Device device_;
  openni::VideoStream depth_, color_;
  bool has_color_ = false;
  std::unique_ptr<DisconnectWatch> watch_;
  openni::PlaybackControl* playback_ = nullptr;
  int total_frames_ = 0;  // depth frames in the recording; 0 when it does not say
  int color_frames_ = 0;  // colour frames in the recording; 0 when it does not say
  int depth_read_ = 0, color_read_ = 0;
  std::deque<openni::VideoFrameRef> depth_queue_, color_queue_;
  FramePacer pacer_;  // recordings with options_.realtime
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
  const std::string wanted = std::to_string(want.width) + "x" + std::to_string(want.height) + "@" +
                             std::to_string(want.fps);
  if (best < 0) {
    return make_error(ErrorCode::kUnsupported, name_ + ": the camera has no depth mode " + wanted +
                                                   " (it has: " + available + ")");
  }
  if (!set_mode(depth_, modes[best])) {
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
        set = set_mode(color_, mode);
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
  if (playback_ != nullptr) color_frames_ = std::max(0, playback_->getNumberOfFrames(color_));
}

// The recording's player: manual pace and its depth frame count.
Status OpenNI2Source::open_playback() {
  playback_ = device_.getPlaybackControl();
  if (playback_ == nullptr) {
    return make_error(ErrorCode::kParseError, name_ + ": not a playable OpenNI2 recording");
  }
  playback_->setRepeatEnabled(false);
  // -1 (manual): the player reads the next record only when a stream is waited on, so no
  // frame is ever dropped. At any positive speed it reads on by itself at that pace and a
  // stream keeps only its newest frame: a consumer slower than the recording loses frames.
  // --realtime is therefore paced here (pacer_), on the recorded timestamps.
  playback_->setSpeed(-1.0f);
  // A recording whose recorder was never closed has no frame count (OpenNI2 reports -1):
  // it plays until its data ends.
  const int frames = playback_->getNumberOfFrames(depth_);
  if (frames == 0) {
    return make_error(ErrorCode::kParseError, name_ + ": the recording holds no depth frame");
  }
  total_frames_ = std::max(0, frames);
  return {};
}

// The depth mode's size with the intrinsics given, else those from the sensor's field of view.
Status OpenNI2Source::set_intrinsics(const openni::VideoMode& mode) {
  intrinsics_.width = mode.getResolutionX();
  intrinsics_.height = mode.getResolutionY();
  if (!options_.intrinsics) return intrinsics_from_fov();
  const Intrinsics& k = *options_.intrinsics;
  if (!(k.fx > 0.0 && k.fy > 0.0 && std::isfinite(k.cx) && std::isfinite(k.cy))) {
    return make_error(ErrorCode::kInvalidArgument,
                      name_ + ": the intrinsics given have a non-positive focal length (fx " +
                          std::to_string(k.fx) + ", fy " + std::to_string(k.fy) + ")");
  }
  intrinsics_.fx = k.fx;
  intrinsics_.fy = k.fy;
  intrinsics_.cx = k.cx;
  intrinsics_.cy = k.cy;
  return {};
}

Status OpenNI2Source::open() {
  IMUFUSION_RETURN_IF_ERROR(acquire_openni());
  acquired_ = true;
  const std::string uri = is_file_ ? name_ : name_.substr(std::string_view("openni2://").size());
  if (!is_file_ && uri.empty()) {
    openni::Array<openni::DeviceInfo> devices;
    openni::OpenNI::enumerateDevices(&devices);
    if (devices.getSize() == 0) {
      return make_error(ErrorCode::kNoDevice,
                        name_ +
                            ": no OpenNI2 camera found (is it plugged in, and is its "
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
                          : "openni2://" + std::string(info.getUri()) + " (" + info.getVendor() +
                                " " + info.getName() + ")";
  if (!device_.hasSensor(openni::SENSOR_DEPTH) ||
      depth_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
    return make_error(is_file_ ? ErrorCode::kParseError : ErrorCode::kUnsupported,
                      name_ + ": no depth stream: " + openni_error());
  }
  if (is_file_) {
    IMUFUSION_RETURN_IF_ERROR(open_playback());
  } else {
    IMUFUSION_RETURN_IF_ERROR(choose_depth_mode());
    watch_ = std::make_unique<DisconnectWatch>(info.getUri());
    openni::OpenNI::addDeviceDisconnectedListener(watch_.get());
  }
  const openni::VideoMode mode = depth_.getVideoMode();
  if (depth_scale_of(mode.getPixelFormat()) == 0.0) {
    return make_error(ErrorCode::kUnsupported, name_ + ": depth pixel format " +
                                                   std::to_string(mode.getPixelFormat()) +
                                                   " is neither 1 mm nor 100 um");
  }
  IMUFUSION_RETURN_IF_ERROR(set_intrinsics(mode));
  if (depth_.start() != openni::STATUS_OK) {
    return make_error(is_file_ ? ErrorCode::kParseError : ErrorCode::kIoError,
                      name_ + ": cannot start the depth stream: " + openni_error());
  }
  open_color();
  return {};
}

Status OpenNI2Source::intrinsics_from_fov() {
  // OpenNI2 reports the depth camera's fields of view (radians); the principal point is taken
  // at the image centre, as OpenNI2's own depth-to-world conversion does.
  const double hfov = depth_.getHorizontalFieldOfView();
  const double vfov = depth_.getVerticalFieldOfView();
  if (!(hfov > 0.0 && hfov < 3.1) || !(vfov > 0.0 && vfov < 3.1) || intrinsics_.width <= 0 ||
      intrinsics_.height <= 0) {
    return make_error(ErrorCode::kUnsupported,
                      name_ + ": the depth stream reports no usable field of view (" +
                          std::to_string(hfov) + ", " + std::to_string(vfov) +
                          " rad); give its intrinsics instead");
  }
  intrinsics_.fx = 0.5 * intrinsics_.width / std::tan(0.5 * hfov);
  intrinsics_.fy = 0.5 * intrinsics_.height / std::tan(0.5 * vfov);
  intrinsics_.cx = 0.5 * (intrinsics_.width - 1);
  intrinsics_.cy = 0.5 * (intrinsics_.height - 1);
  return {};
}

Result<bool> OpenNI2Source::wait_for_depth() {
  openni::VideoStream* streams[] = {&depth_};
  int ready = -1;
  const openni::Status status = openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms());
  if (status == openni::STATUS_OK) return true;
  if (status == openni::STATUS_TIME_OUT) return false;
  return make_error(ErrorCode::kDeviceLost,
                    name_ + ": waiting for a depth frame failed: " + openni_error());
}

ColorImage color_image(const openni::VideoFrameRef& ref) {
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
  return color;
}

// Device clock, microseconds, as seconds.
double stamp_of(const openni::VideoFrameRef& ref) {
  return static_cast<double>(ref.getTimestamp()) * 1e-6;
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
    if (stamp_of(ref) >= device_time) break;
  }
  if (!have || ref.getWidth() != intrinsics_.width || ref.getHeight() != intrinsics_.height) {
    return;
  }
  frame->color = color_image(ref);
  frame->color_timestamp = clock_.to_host(stamp_of(ref));
}

std::optional<Frame> OpenNI2Source::depth_frame(const openni::VideoFrameRef& ref) {
  const double device_time = stamp_of(ref);
  const double scale = depth_scale_of(ref.getVideoMode().getPixelFormat());
  if (device_time <= last_device_time_ || scale == 0.0 || ref.getWidth() != intrinsics_.width ||
      ref.getHeight() != intrinsics_.height) {
    return std::nullopt;
  }
  last_device_time_ = device_time;
  Frame frame;
  frame.index = delivered_++;
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
  return frame;
}

Result<std::optional<Frame>> OpenNI2Source::next() {
  return is_file_ ? next_recorded() : next_live();
}

Result<std::optional<Frame>> OpenNI2Source::next_live() {
  while (true) {
    if (watch_ && watch_->lost()) {
      return make_error(ErrorCode::kDeviceLost, description_ + ": camera disconnected");
    }
    auto ready = wait_for_depth();
    if (!ready.ok()) return ready.error();
    if (!*ready) {
      return make_error(ErrorCode::kDeviceLost, description_ + ": no depth frame for " +
                                                    std::to_string(options_.frame_timeout) +
                                                    " s (camera unplugged?)");
    }
    openni::VideoFrameRef ref;
    if (depth_.readFrame(&ref) != openni::STATUS_OK) {
      return make_error(ErrorCode::kDeviceLost,
                        name_ + ": reading a depth frame failed: " + openni_error());
    }
    std::optional<Frame> frame = depth_frame(ref);
    if (!frame) continue;
    // The mapping's offset may drop by more than a frame interval after a delayed first
    // frame; stamps stay strictly increasing (1 us apart at worst) as a Frame requires.
    frame->timestamp =
        std::max(clock_.observe(host_clock_now(), stamp_of(ref)), last_host_time_ + 1e-6);
    last_host_time_ = frame->timestamp;
    if (has_color_) read_color_until(stamp_of(ref), &*frame);
    return frame;
  }
}

Result<bool> OpenNI2Source::read_recorded() {
  // In manual playback each wait lets the player read one more record, so a frame waits in its
  // stream until it is read here and none is overwritten.
  openni::VideoStream* streams[] = {&depth_, &color_};
  const int count = has_color_ && !color_done() ? 2 : 1;
  int ready = -1;
  const openni::Status status =
      openni::OpenNI::waitForAnyStream(streams, count, &ready, timeout_ms());
  if (status == openni::STATUS_TIME_OUT) return false;
  openni::VideoFrameRef ref;
  if (status != openni::STATUS_OK || ready < 0 || ready >= count ||
      streams[ready]->readFrame(&ref) != openni::STATUS_OK) {
    return make_error(ErrorCode::kParseError, name_ + ": reading frame " +
                                                  std::to_string(depth_read_ + color_read_ + 1) +
                                                  " of the recording failed: " + openni_error());
  }
  if (ready == 0) {
    ++depth_read_;
    depth_queue_.push_back(ref);
  } else {
    ++color_read_;
    color_queue_.push_back(ref);
  }
  return true;
}

void OpenNI2Source::pair_recorded_color(double device_time, Frame* frame) {
  // Colour frames come in file order: read on until one is stamped at or after the depth
  // frame, unless the colour stream has ended or two later depth frames are already queued
  // (colour lagging that far has no closer partner than what was read).
  while ((color_queue_.empty() || stamp_of(color_queue_.back()) < device_time) && !color_done() &&
         depth_queue_.size() < 2) {
    auto more = read_recorded();
    if (!more.ok() || !*more) break;  // the depth stream reports the end or the error
  }
  // The nearest one; those before it are farther from every later depth frame too.
  while (color_queue_.size() >= 2 && std::abs(stamp_of(color_queue_[1]) - device_time) <=
                                         std::abs(stamp_of(color_queue_[0]) - device_time)) {
    color_queue_.pop_front();
  }
  if (color_queue_.empty()) return;
  const openni::VideoFrameRef& ref = color_queue_.front();
  if (ref.getWidth() != intrinsics_.width || ref.getHeight() != intrinsics_.height) return;
  frame->color = color_image(ref);
  frame->color_timestamp = stamp_of(ref);
}

Result<std::optional<Frame>> OpenNI2Source::next_recorded() {
  while (true) {
    while (depth_queue_.empty()) {
      if (total_frames_ > 0 && depth_read_ >= total_frames_) {
        // At the end of the file the playback thread spins on while a stream is started.
        if (color_.isValid()) color_.stop();
        depth_.stop();
        return std::optional<Frame>();
      }
      auto more = read_recorded();
      if (!more.ok()) return more.error();
      if (!*more) {
        const std::string of = total_frames_ > 0 ? " of " + std::to_string(total_frames_) : "";
        return make_error(ErrorCode::kParseError, name_ + ": no depth frame after frame " +
                                                      std::to_string(depth_read_) + of +
                                                      " (truncated recording?)");
      }
    }
    const openni::VideoFrameRef ref = depth_queue_.front();
    depth_queue_.pop_front();
    std::optional<Frame> frame = depth_frame(ref);
    if (!frame) continue;
    frame->timestamp = stamp_of(ref);  // the recording's clock
    if (has_color_) pair_recorded_color(frame->timestamp, &*frame);
    if (options_.realtime) pacer_.wait_for(frame->timestamp);
    return frame;
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
                    name +
                        ": this build of imufusion has no OpenNI2 support (install "
                        "libopenni2-dev and reconfigure)");
}

}  // namespace io

bool openni2_available() { return false; }

}  // namespace imufusion

#endif

#include "imufusion/recorder.hpp"

#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include "io/text_table.hpp"

namespace imufusion {

struct SessionRecorder::State {
  RecorderOptions options;
  std::filesystem::path directory;
  SequenceWriter writer;  // used by the worker until it is joined, then by finish()
  std::thread worker;

  mutable std::mutex mutex;  // guards everything below
  std::condition_variable wake;
  std::deque<Frame> queue;
  bool closing = false;
  bool finished = false;
  Status first_error;
  RecorderStats stats;
  std::vector<ImuSample> imu;          // as pushed, on the IMU clock
  std::vector<ImuSample> imu_pending;  // shifted by the offset of their push, for the worker
  double imu_clock_offset = 0.0;
  bool has_imu_clock_offset = false;
  std::optional<Intrinsics> intrinsics;
  std::optional<Eigen::Isometry3d> T_camera_imu;
  std::vector<std::pair<std::string, std::string>> info;
  bool metadata_changed = false;  // intrinsics, T_camera_imu or info set since the writer had them
  // The worker's alone: the newest IMU timestamp it gave the writer.
  std::optional<double> last_written_imu;

  explicit State(SequenceWriter w) : writer(std::move(w)) {}

  void record_error(const Status& status) {
    if (!status.ok() && first_error.ok()) first_error = status;
  }

  // What the writer writes besides frames and IMU (calibration.txt, imu_to_camera.txt, info.txt).
  struct Metadata {
    std::optional<Intrinsics> intrinsics;
    std::optional<Eigen::Isometry3d> T_camera_imu;
    std::vector<std::pair<std::string, std::string>> info;
  };

  // The metadata set since the writer last had it (the caller holds the lock).
  std::optional<Metadata> take_metadata() {
    if (!metadata_changed) return std::nullopt;
    metadata_changed = false;
    return Metadata{intrinsics, T_camera_imu, info};
  }

  // Outside the lock, by the writer's thread (the worker, or finish() once it is joined).
  Status apply(const std::optional<Metadata>& metadata) {
    if (!metadata) return {};
    if (metadata->intrinsics)
      IMUFUSION_RETURN_IF_ERROR(writer.set_intrinsics(*metadata->intrinsics));
    if (metadata->T_camera_imu) {
      IMUFUSION_RETURN_IF_ERROR(writer.set_T_camera_imu(*metadata->T_camera_imu));
    }
    for (const auto& [key, value] : metadata->info) {
      IMUFUSION_RETURN_IF_ERROR(writer.set_info(key, value));
    }
    return {};
  }

  // The samples pushed since the last frame, before the frame's depth line: a frame on disk has
  // its IMU on disk. A sample not after the last one written (the offset moved back) waits for
  // finish(), which rewrites imu.txt.
  Status write_pending_imu(const std::vector<ImuSample>& samples) {
    for (const ImuSample& sample : samples) {
      if (last_written_imu && !(sample.timestamp > *last_written_imu)) continue;
      IMUFUSION_RETURN_IF_ERROR(writer.add_imu(sample));
      last_written_imu = sample.timestamp;
    }
    return {};
  }

  void run() {
    std::unique_lock lock(mutex);
    while (true) {
      wake.wait(lock, [&] { return closing || !queue.empty(); });
      if (queue.empty()) return;  // closing and drained
      Frame frame = std::move(queue.front());
      queue.pop_front();
      const bool failed = !first_error.ok();
      const std::optional<Metadata> metadata = take_metadata();
      std::vector<ImuSample> samples;
      samples.swap(imu_pending);
      lock.unlock();
      // Encoding and disk writes happen outside the lock, so push_frame never waits on them.
      Status status;
      if (!failed) status = apply(metadata);
      if (!failed && status.ok()) status = write_pending_imu(samples);
      if (!failed && status.ok()) {
        status = writer.add_depth(frame.timestamp, frame.depth);
        if (status.ok() && frame.color) {
          status = writer.add_color(frame.color_timestamp, *frame.color);
        }
      }
      lock.lock();
      record_error(status);
      if (failed || !status.ok()) {
        ++stats.frames_dropped;
      } else {
        ++stats.frames_written;
      }
    }
  }

  void stop_worker() {
    {
      std::lock_guard lock(mutex);
      closing = true;
    }
    wake.notify_all();
    if (worker.joinable()) worker.join();
  }
};

Result<SessionRecorder> SessionRecorder::create(const std::filesystem::path& directory,
                                                const RecorderOptions& options) {
  if (options.max_queued_frames == 0) {
    return make_error(ErrorCode::kInvalidArgument, "recorder max_queued_frames must be positive");
  }
  SequenceWriter::Options writer_options = options.writer;
  writer_options.write_as_you_go = true;
  auto writer = SequenceWriter::create(directory, writer_options);
  if (!writer.ok()) return writer.error();
  auto state = std::make_unique<State>(std::move(writer).value());
  state->options = options;
  state->directory = directory;
  State* raw = state.get();
  state->worker = std::thread([raw] { raw->run(); });
  return SessionRecorder(std::move(state));
}

SessionRecorder::SessionRecorder(std::unique_ptr<State> state) : state_(std::move(state)) {}
SessionRecorder::SessionRecorder(SessionRecorder&&) noexcept = default;
SessionRecorder& SessionRecorder::operator=(SessionRecorder&& other) noexcept {
  if (this != &other) {
    if (state_) state_->stop_worker();
    state_ = std::move(other.state_);
  }
  return *this;
}
SessionRecorder::~SessionRecorder() {
  if (state_) state_->stop_worker();
}

bool SessionRecorder::push_frame(Frame frame) {
  {
    std::lock_guard lock(state_->mutex);
    if (state_->closing || !state_->first_error.ok() ||
        state_->queue.size() >= state_->options.max_queued_frames) {
      ++state_->stats.frames_dropped;
      return false;
    }
    frame.imu.clear();
    state_->queue.push_back(std::move(frame));
    ++state_->stats.frames_queued;
  }
  state_->wake.notify_one();
  return true;
}

void SessionRecorder::push_imu(const std::vector<ImuSample>& samples) {
  std::lock_guard lock(state_->mutex);
  for (const ImuSample& sample : samples) {
    const bool finite =
        std::isfinite(sample.timestamp) && sample.gyro.allFinite() && sample.accel.allFinite();
    if (!finite || (!state_->imu.empty() && !(sample.timestamp > state_->imu.back().timestamp))) {
      ++state_->stats.imu_dropped;
      continue;
    }
    state_->imu.push_back(sample);
    ImuSample shifted = sample;
    shifted.timestamp += state_->imu_clock_offset;
    state_->imu_pending.push_back(shifted);
    ++state_->stats.imu_samples;
  }
}

void SessionRecorder::set_imu_clock_offset(double offset) {
  std::lock_guard lock(state_->mutex);
  state_->imu_clock_offset = offset;
  state_->has_imu_clock_offset = true;
}

void SessionRecorder::set_intrinsics(const Intrinsics& intrinsics) {
  std::lock_guard lock(state_->mutex);
  state_->intrinsics = intrinsics;
  state_->metadata_changed = true;
}

void SessionRecorder::set_T_camera_imu(const Eigen::Isometry3d& T_camera_imu) {
  std::lock_guard lock(state_->mutex);
  state_->T_camera_imu = T_camera_imu;
  state_->metadata_changed = true;
}

void SessionRecorder::set_info(const std::string& key, const std::string& value) {
  std::lock_guard lock(state_->mutex);
  state_->info.emplace_back(key, value);
  state_->metadata_changed = true;
}

Status SessionRecorder::status() const {
  std::lock_guard lock(state_->mutex);
  return state_->first_error;
}

RecorderStats SessionRecorder::stats() const {
  std::lock_guard lock(state_->mutex);
  return state_->stats;
}

const std::filesystem::path& SessionRecorder::directory() const { return state_->directory; }

Status SessionRecorder::finish() {
  state_->stop_worker();
  // The worker is joined: the writer and the session data are this thread's alone now.
  State& s = *state_;
  if (s.finished) return s.first_error;
  s.finished = true;
  if (!s.first_error.ok()) return s.first_error;
  s.record_error(s.apply(s.take_metadata()));
  // imu.txt again, whole, on the final clock offset.
  s.writer.forget_imu();
  if (s.has_imu_clock_offset) {
    s.record_error(s.writer.set_info("imu_clock_offset", io::format_exact(s.imu_clock_offset)));
  }
  for (ImuSample sample : s.imu) {
    if (!s.first_error.ok()) break;
    sample.timestamp += s.imu_clock_offset;
    s.record_error(s.writer.add_imu(sample));
  }
  if (s.first_error.ok()) s.record_error(s.writer.finish());
  return s.first_error;
}

}  // namespace imufusion

#include <algorithm>
#include <cmath>

#include "imufusion/image_io.hpp"
#include "imufusion/sequence.hpp"
#include "io/sequence_index.hpp"

namespace imufusion {

struct SequenceReader::State {
  SequenceInfo info;
  SequenceOptions options;
  std::vector<double> imu_stamps;  // info.imu timestamps, for binary search
  std::size_t cursor = 0;
};

SequenceReader::SequenceReader(std::unique_ptr<State> state) : state_(std::move(state)) {}
SequenceReader::SequenceReader(SequenceReader&&) noexcept = default;
SequenceReader& SequenceReader::operator=(SequenceReader&&) noexcept = default;
SequenceReader::~SequenceReader() = default;

Result<SequenceReader> SequenceReader::open(const std::filesystem::path& directory,
                                            const SequenceOptions& options) {
  if (!(options.max_color_time_difference >= 0) || !(options.first_frame_imu_lookback >= 0)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "SequenceOptions: max_color_time_difference and first_frame_imu_lookback "
                      "must be non-negative");
  }
  io::SequenceIndex index = io::load_sequence_index(directory, options);
  if (!index.problems.empty()) {
    Error first = index.problems.front();
    if (index.problems.size() > 1) {
      first.message += " (and " + std::to_string(index.problems.size() - 1) +
                       " more problems; imufusion-info lists them all)";
    }
    return first;
  }
  auto state = std::make_unique<State>();
  state->info = std::move(index.info);
  state->options = options;
  state->imu_stamps.reserve(state->info.imu.size());
  for (const ImuSample& sample : state->info.imu) state->imu_stamps.push_back(sample.timestamp);
  return SequenceReader(std::move(state));
}

const SequenceInfo& SequenceReader::info() const { return state_->info; }
std::size_t SequenceReader::frame_count() const { return state_->info.depth.size(); }

std::vector<double> SequenceReader::timestamps() const {
  std::vector<double> stamps;
  stamps.reserve(state_->info.depth.size());
  for (const auto& entry : state_->info.depth) stamps.push_back(entry.timestamp);
  return stamps;
}

const std::optional<Intrinsics>& SequenceReader::intrinsics() const {
  return state_->info.intrinsics;
}
const Eigen::Isometry3d& SequenceReader::T_camera_imu() const { return state_->info.T_camera_imu; }
bool SequenceReader::has_ground_truth() const { return state_->info.has_ground_truth; }
const Trajectory& SequenceReader::ground_truth() const { return state_->info.ground_truth; }
bool SequenceReader::has_imu() const { return state_->info.has_imu; }
const std::vector<ImuSample>& SequenceReader::imu() const { return state_->info.imu; }

Result<Frame> SequenceReader::frame(std::size_t index) const {
  const SequenceInfo& info = state_->info;
  if (index >= info.depth.size()) {
    return make_error(ErrorCode::kInvalidArgument,
                      info.directory.string() + ": frame " + std::to_string(index) +
                          " requested, the sequence has " + std::to_string(info.depth.size()));
  }
  const ImageIndexEntry& entry = info.depth[index];
  Frame frame;
  frame.index = index;
  frame.timestamp = entry.timestamp;
  auto depth = read_depth_png(entry.path, info.depth_scale);
  if (!depth.ok()) return depth.error();
  if (depth->width != info.width || depth->height != info.height) {
    return make_error(ErrorCode::kParseError,
                      entry.path.string() + ": image size " + std::to_string(depth->width) + "x" +
                          std::to_string(depth->height) + " differs from the sequence's " +
                          std::to_string(info.width) + "x" + std::to_string(info.height));
  }
  frame.depth = std::move(*depth);

  const int color_index = info.color_of_depth[index];
  if (state_->options.load_color && color_index >= 0) {
    const ImageIndexEntry& color_entry = info.color[static_cast<std::size_t>(color_index)];
    auto color = read_color_image(color_entry.path);
    if (!color.ok()) return color.error();
    if (color->width != frame.depth.width || color->height != frame.depth.height) {
      return make_error(ErrorCode::kParseError,
                        color_entry.path.string() + ": colour size " +
                            std::to_string(color->width) + "x" + std::to_string(color->height) +
                            " differs from the depth size " + std::to_string(frame.depth.width) +
                            "x" + std::to_string(frame.depth.height) + " of " +
                            entry.path.string());
    }
    frame.color = std::move(*color);
    frame.color_timestamp = color_entry.timestamp;
  }

  const double from = index == 0 ? entry.timestamp - state_->options.first_frame_imu_lookback
                                 : info.depth[index - 1].timestamp;
  frame.imu = imu_between(from, entry.timestamp);
  return frame;
}

std::vector<ImuSample> SequenceReader::imu_between(double from, double to) const {
  // upper_bound finds the first stamp strictly after a bound.
  const auto& stamps = state_->imu_stamps;
  const auto begin = std::upper_bound(stamps.begin(), stamps.end(), from) - stamps.begin();
  const auto end = std::upper_bound(stamps.begin(), stamps.end(), to) - stamps.begin();
  if (end <= begin) return {};
  return {state_->info.imu.begin() + begin, state_->info.imu.begin() + end};
}

Result<Frame> SequenceReader::next() {
  if (done()) {
    return make_error(ErrorCode::kInvalidArgument, state_->info.directory.string() +
                                                       ": no frame after the last one (" +
                                                       std::to_string(frame_count()) + " frames)");
  }
  return frame(state_->cursor++);
}

bool SequenceReader::done() const { return state_->cursor >= state_->info.depth.size(); }

void SequenceReader::seek(std::size_t index) {
  state_->cursor = std::min(index, state_->info.depth.size());
}

}  // namespace imufusion

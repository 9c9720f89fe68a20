#pragma once
// The Reconstructor tests' fixture: a small synthetic room (160x120, 36 frames with IMU) read once
// per suite, and helpers that scan it with faults injected.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include "../support/scratch_dir.hpp"
#include "../support/synth_config.hpp"
#include "gpu_test_env.hpp"
#include "imufusion/eval.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/scan_report.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"
#include "imufusion/trajectory.hpp"

namespace imufusion::test {

namespace fs = std::filesystem;

inline double rotation_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

class ReconstructorTest : public GpuTest {
 protected:
  static void SetUpTestSuite() {
    std::random_device random;
    root_ = new fs::path(fs::temp_directory_path() /
                         ("imufusion_reconstructor_" + std::to_string(random())));
    const synth::SynthConfig config = test::small_synth_config(synth::SceneKind::kRoom, 11, 36);
    synth_ok_ = synth::synthesize(config, *root_ / "room").ok();
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(*root_, ec);
    delete root_;
  }

  void SetUp() override {
    test::GpuTest::SetUp();
    if (IsSkipped() || HasFatalFailure()) return;
    ASSERT_TRUE(synth_ok_);
    auto reader = SequenceReader::open(*root_ / "room");
    ASSERT_TRUE(reader.ok()) << reader.error().describe();
    reader_.emplace(std::move(*reader));
    for (std::size_t i = 0; i < reader_->frame_count(); ++i) {
      auto frame = reader_->next();
      ASSERT_TRUE(frame.ok()) << frame.error().describe();
      frames_.push_back(std::move(*frame));
    }
  }

  ReconstructorConfig config(bool imu, int iterations) const {
    ReconstructorConfig c;
    c.intrinsics = *reader_->intrinsics();
    c.intrinsics.width = 160;
    c.intrinsics.height = 120;
    c.imu.enabled = imu;
    c.icp.max_total_iterations = iterations;
    c.inertial.T_camera_imu = reader_->T_camera_imu();
    c.device.selector = context_->info().name;
    c.device.validation = true;
    c.volume.block_capacity = 1u << 13;
    c.volume.hash_slots = 1u << 15;
    return c;
  }

  Reconstructor make(const ReconstructorConfig& c) {
    auto rec = Reconstructor::create(c);
    EXPECT_TRUE(rec.ok()) << rec.error().describe();
    return std::move(*rec);
  }

  double ate(const Trajectory& estimate) const {
    auto result = evaluate_ate(reader_->ground_truth(), estimate);
    EXPECT_TRUE(result.ok()) << result.error().describe();
    return result.ok() ? result->stats.rmse : std::numeric_limits<double>::infinity();
  }

  // Position error of a pose against the ground truth, in the scan's world (the first frame's
  // camera); infinity where the truth has no pose at its time.
  double position_error(const StampedPose& pose) const {
    const StampedPose* truth = find_pose(reader_->ground_truth(), pose.timestamp);
    if (truth == nullptr) return std::numeric_limits<double>::infinity();
    const Eigen::Isometry3d T0 = reader_->ground_truth().front().T_world_camera;
    return ((T0.inverse() * truth->T_world_camera).translation() -
            pose.T_world_camera.translation())
        .norm();
  }

  // Frames 0 to `last`, those `blank` names with no depth, the accelerometer reading
  // `accel_error(i)` m/s^2 too much along x over frame i (at 30 fps, 12 m/s^2 over one frame is
  // 0.4 m/s). Stops at the first error.
  std::vector<FrameResult> scan_jolted(Reconstructor& rec, std::size_t last,
                                       const std::function<double(std::size_t)>& accel_error,
                                       const std::function<bool(std::size_t)>& blank) const {
    std::vector<FrameResult> results;
    for (std::size_t i = 0; i <= last && i < frames_.size(); ++i) {
      const Frame& f = frames_[i];
      DepthImage depth = f.depth;
      if (blank(i)) std::fill(depth.data.begin(), depth.data.end(), 0);
      std::vector<ImuSample> imu = f.imu;
      for (ImuSample& sample : imu) sample.accel.x() += accel_error(i);
      auto r = rec.track_and_fuse(f.timestamp, depth, nullptr, imu);
      EXPECT_TRUE(r.ok()) << r.error().describe();
      if (!r.ok()) break;
      results.push_back(*r);
    }
    return results;
  }

  // The first frame that ended a loss (results.size() when none did).
  static std::size_t first_recovered(const std::vector<FrameResult>& results,
                                     std::size_t from = 0) {
    std::size_t back = from;
    while (back < results.size() && !results[back].recovered) ++back;
    return back;
  }

  inline static fs::path* root_ = nullptr;
  inline static bool synth_ok_ = false;
  std::optional<SequenceReader> reader_;
  std::vector<Frame> frames_;
};

}  // namespace imufusion::test

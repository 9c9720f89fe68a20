// imufusion-scan with a given IMU mounting that disagrees with the motion: the synthesizer's
// phone IMU is mounted 180 deg from the camera, so an imu_to_camera.txt overwritten with the
// identity is wrong. The scan warns once on stderr and summary.json's camera_imu_check says so;
// the sequence as synthesized neither warns nor disagrees.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "scan_test_fixtures.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

// Frames: the check needs 60 reliable frame pairs with enough rotation and runs every 30.
constexpr int kFrames = 240;
constexpr std::uint64_t kSeed = 5;

class ScanImuMounting : public test::ScanToolTest {
 protected:
  ScanImuMounting() : ScanToolTest("imufusion_mounting_") {}

  // Scans `seq` into `out`; returns stderr, with summary.json in `summary`.
  std::string scan_into(const fs::path& seq, const std::string& out, nlohmann::json& summary) {
    const auto run = scan(seq.string() + " --out " + path(out).string() + " --quiet");
    EXPECT_EQ(run.exit_code, 0) << run.err;
    summary = test::read_json(path(out) / "summary.json");
    return run.err;
  }
};

std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST_F(ScanImuMounting, AWrongGivenMountingIsReportedOnce) {
  const fs::path seq =
      test::synthesize_small(scratch_.path(), "room", synth::SceneKind::kRoom, kFrames, kSeed);
  ASSERT_TRUE(fs::exists(seq / "imu_to_camera.txt"));
  std::ofstream(seq / "imu_to_camera.txt") << "0 0 0 1 0 0 0\n";  // qx qy qz qw tx ty tz
  nlohmann::json summary;
  const std::string err = scan_into(seq, "out", summary);
  EXPECT_EQ(occurrences(err, "disagrees with the motion"), 1u) << err;
  EXPECT_NE(err.find("--estimate-imu-rotation"), std::string::npos) << err;
  const auto& check = summary["imu_estimates"]["camera_imu_check"];
  ASSERT_TRUE(check.is_object()) << summary.dump(2);
  EXPECT_TRUE(check["disagrees"].get<bool>()) << summary.dump(2);
  // The synthesizer's IMU is 180 deg from the camera.
  EXPECT_GT(check["angle_deg"].get<double>(), 150.0) << check.dump();
}

TEST_F(ScanImuMounting, TheRightMountingIsNotReported) {
  const fs::path seq =
      test::synthesize_small(scratch_.path(), "room", synth::SceneKind::kRoom, kFrames, kSeed);
  nlohmann::json summary;
  const std::string err = scan_into(seq, "out", summary);
  EXPECT_EQ(err.find("disagrees with the motion"), std::string::npos) << err;
  const auto& check = summary["imu_estimates"]["camera_imu_check"];
  ASSERT_TRUE(check.is_object()) << summary.dump(2);
  EXPECT_FALSE(check["disagrees"].get<bool>());
  EXPECT_LT(check["angle_deg"].get<double>(), 5.0);
  // The check ran: the hand-eye estimate has its pairs.
  EXPECT_GE(summary["imu_estimates"]["hand_eye_pairs"].get<int>(), 60) << summary.dump(2);
}

}  // namespace
}  // namespace imufusion

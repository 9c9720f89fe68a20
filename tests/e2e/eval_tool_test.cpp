#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const fs::path kTool = fs::path(IMUFUSION_TEST_BINARY_DIR) / "tools" / "imufusion-eval";

struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

std::string read_all(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

class EvalTool : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("imufusion_eval_tool_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  RunResult run(const std::string& arguments) const {
    const fs::path out = dir_ / "stdout.txt";
    const fs::path err = dir_ / "stderr.txt";
    const std::string command = "'" + kTool.string() + "' " + arguments + " >'" + out.string() +
                                "' 2>'" + err.string() + "'";
    const int status = std::system(command.c_str());
    RunResult result;
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    result.out = read_all(out);
    result.err = read_all(err);
    return result;
  }

  fs::path write(const std::string& name, const std::string& content) const {
    const fs::path path = dir_ / name;
    std::ofstream(path) << content;
    return path;
  }

  fs::path dir_;
};

std::string tum_line(double t, const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.linear());
  const Eigen::Vector3d p = pose.translation();
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", t, p.x(),
                p.y(), p.z(), q.x(), q.y(), q.z(), q.w());
  return buffer;
}

// Ground truth: four poses on the plus A(1,0,0) B(-1,0,0) C(0,1,0) D(0,-1,0). Estimate: A and B
// lifted by d along z, then the whole estimate moved rigidly into another world frame. After
// the rigid alignment every pose is off by exactly d/2 (centroid shift d/2; the cross-covariance
// is diag(2,2,0), so no rotation helps; see eval_ate_test.cpp), hence ate_rmse = d/2.
constexpr double kLift = 0.1;  // metres

std::string plus_groundtruth() {
  const std::vector<Eigen::Vector3d> plus{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  std::string text = "# timestamp tx ty tz qx qy qz qw\n";
  for (std::size_t k = 0; k < plus.size(); ++k) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = plus[k];
    text += tum_line(1305031101.0 + 0.1 * static_cast<double>(k), pose);
  }
  return text;
}

std::string plus_estimate() {
  const std::vector<Eigen::Vector3d> plus{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  Eigen::Isometry3d T_est_gt = Eigen::Isometry3d::Identity();
  T_est_gt.linear() = Eigen::AngleAxisd(0.9, Eigen::Vector3d(1, -2, 0.5).normalized()).matrix();
  T_est_gt.translation() = Eigen::Vector3d(3, -1, 0.25);
  std::string text;
  for (std::size_t k = 0; k < plus.size(); ++k) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = plus[k] + Eigen::Vector3d(0, 0, k < 2 ? kLift : 0.0);
    // 4 ms after the ground-truth stamp: inside the 20 ms association window.
    text += tum_line(1305031101.004 + 0.1 * static_cast<double>(k), T_est_gt * pose);
  }
  return text;
}

TEST_F(EvalTool, JsonReportsTheHandComputedAte) {
  const fs::path gt = write("groundtruth.txt", plus_groundtruth());
  const fs::path est = write("estimate.txt", plus_estimate());
  const RunResult result = run("'" + gt.string() + "' '" + est.string() + "' --json");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  // Exactly one JSON object on stdout: parsing the whole of it must succeed.
  const nlohmann::json json = nlohmann::json::parse(result.out);
  ASSERT_TRUE(json.is_object());
  EXPECT_EQ(json.at("matched").get<int>(), 4);
  // Positions are written with 9 decimals, so 1e-8 m of rounding is all that may differ.
  EXPECT_NEAR(json.at("ate_rmse").get<double>(), kLift / 2, 1e-7);
  EXPECT_NEAR(json.at("ate_max").get<double>(), kLift / 2, 1e-7);
  EXPECT_NEAR(json.at("ate_median").get<double>(), kLift / 2, 1e-7);
  for (const char* key : {"ate_mean", "rpe_frame_trans_rmse", "rpe_frame_rot_rmse_deg",
                          "rpe_second_trans_rmse", "rpe_second_rot_rmse_deg"}) {
    EXPECT_TRUE(json.contains(key)) << key;
  }
}

TEST_F(EvalTool, HumanSummaryGivesCountsAndCentimetres) {
  const fs::path gt = write("groundtruth.txt", plus_groundtruth());
  const fs::path est = write("estimate.txt", plus_estimate());
  const RunResult result = run("'" + gt.string() + "' '" + est.string() + "'");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("matched       4 of 4 ground-truth and 4 of 4 estimate poses"),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("rmse 5.000"), std::string::npos) << result.out;  // d/2 in cm
  EXPECT_NE(result.out.find("RPE per frame (3 pairs)"), std::string::npos) << result.out;
}

TEST_F(EvalTool, MalformedFileFailsWithItsName) {
  const fs::path gt = write("groundtruth.txt", plus_groundtruth());
  const fs::path bad = write("broken_estimate.txt", "1305031101.0 1.0 2.0 not-a-number\n");
  const RunResult result = run("'" + gt.string() + "' '" + bad.string() + "' --json");
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("broken_estimate.txt"), std::string::npos) << result.err;
  EXPECT_TRUE(result.out.empty()) << result.out;
}

TEST_F(EvalTool, MissingAndEmptyFilesFailWithTheirNames) {
  const fs::path gt = write("groundtruth.txt", plus_groundtruth());
  const RunResult missing = run("'" + gt.string() + "' '" + (dir_ / "absent.txt").string() + "'");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("absent.txt"), std::string::npos) << missing.err;

  const fs::path empty = write("only_comments.txt", "# timestamp tx ty tz qx qy qz qw\n");
  const RunResult no_poses = run("'" + empty.string() + "' '" + gt.string() + "'");
  EXPECT_EQ(no_poses.exit_code, 1);
  EXPECT_NE(no_poses.err.find("only_comments.txt"), std::string::npos) << no_poses.err;
}

TEST_F(EvalTool, DisjointClocksFailNamingBothSpans) {
  const fs::path gt = write("groundtruth.txt", plus_groundtruth());
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const fs::path est = write("estimate.txt", tum_line(0.0, pose) + tum_line(0.1, pose) +
                                                 tum_line(0.2, pose) + tum_line(0.3, pose));
  const RunResult result = run("'" + gt.string() + "' '" + est.string() + "'");
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("only 0 poses matched"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("0.000000 .. 0.300000 s"), std::string::npos) << result.err;
}

TEST_F(EvalTool, UsageErrorsExitWithTwo) {
  EXPECT_EQ(run("").exit_code, 2);
  EXPECT_EQ(run("a.txt").exit_code, 2);
  EXPECT_EQ(run("a.txt b.txt --max-difference").exit_code, 2);
  EXPECT_EQ(run("a.txt b.txt --max-difference soon").exit_code, 2);
  EXPECT_EQ(run("a.txt b.txt --delta 1.5 --delta-unit f").exit_code, 2);
  EXPECT_EQ(run("a.txt b.txt --delta-unit m").exit_code, 2);
  EXPECT_EQ(run("a.txt b.txt --frobnicate").exit_code, 2);
  EXPECT_EQ(run("--help").exit_code, 0);
}

}  // namespace

// Memory over a long scan: the same small frame (the synthetic room, seen from one pose) fed to
// the Reconstructor N times with a still IMU at 200 Hz, the process's resident memory (VmRSS)
// sampled as it goes. After warm-up a scanner that keeps only what it needs grows by its
// trajectory (one StampedPose, 136 bytes, a frame); anything more is a leak.
//
//   soak [--frames N] [--size WxH] [--every K] [--keep-results]
//
//   --frames N       frames fed (default 10000)
//   --size WxH       image size (default 80x60)
//   --every K        RSS sampled every K frames (default 500)
//   --keep-results   also keep each FrameResult, as imufusion-scan did before it kept a row of
//                    frames.csv instead
// Printed: RSS (MiB) at each sample, then the growth after warm-up (the first 10%) in bytes a
// frame by least squares, and what the trajectory accounts for.

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "imufusion/reconstructor.hpp"
#include "imufusion/synth.hpp"

using namespace imufusion;

namespace {

// Resident memory of this process, bytes (/proc/self/status VmRSS).
double rss_bytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return 1024.0 * std::strtod(line.c_str() + 6, nullptr);
  }
  return 0;
}

// Least-squares slope of y over x.
double slope(const std::vector<double>& x, const std::vector<double>& y) {
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < x.size(); ++i) mx += x[i], my += y[i];
  mx /= static_cast<double>(x.size());
  my /= static_cast<double>(y.size());
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    sxy += (x[i] - mx) * (y[i] - my), sxx += (x[i] - mx) * (x[i] - mx);
  return sxx > 0 ? sxy / sxx : 0;
}

}  // namespace

int main(int argc, char** argv) {
  long frames = 10000, every = 500;
  int width = 80, height = 60;
  bool keep_results = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--keep-results") {
      keep_results = true;
    } else if (i + 1 < argc && a == "--frames") {
      frames = std::atol(argv[++i]);
    } else if (i + 1 < argc && a == "--every") {
      every = std::atol(argv[++i]);
    } else if (i + 1 < argc && a == "--size" &&
               std::sscanf(argv[i + 1], "%dx%d", &width, &height) == 2) {
      ++i;
    } else {
      std::fprintf(stderr, "usage: soak [--frames N] [--size WxH] [--every K] [--keep-results]\n");
      return 2;
    }
  }
  if (frames < 20 || every < 1 || width < 16 || height < 12) {
    std::fprintf(stderr, "soak: --frames >= 20, --every >= 1, --size >= 16x12\n");
    return 2;
  }
  const Intrinsics k = synth::default_intrinsics(width, height);
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 7);
  const synth::CameraMotion motion(synth::SceneKind::kRoom, 7);
  const Eigen::Isometry3d pose = motion.pose_at(0.0);
  const synth::RenderedFrame frame =
      synth::render_frame(scene, pose, k, synth::SensorModel{}, 7, false);

  ReconstructorConfig config;
  config.intrinsics = k;
  config.imu.enabled = true;
  auto rec = Reconstructor::create(config);
  if (!rec) {
    std::fprintf(stderr, "soak: %s\n", rec.error().describe().c_str());
    return 1;
  }
  // At rest: no rotation, gravity along the camera's -y (up is +y in the IMU's reading).
  const Eigen::Vector3d up_in_camera = pose.linear().transpose() * Eigen::Vector3d(0, 0, 9.81);
  std::vector<FrameResult> kept;
  std::vector<double> at_frame, rss;
  constexpr double kFramePeriod = 1.0 / 30.0, kImuPeriod = 1.0 / 200.0;
  double next_imu = 0;
  std::printf("%10s %10s\n", "frame", "RSS MiB");
  for (long i = 0; i < frames; ++i) {
    const double t = static_cast<double>(i) * kFramePeriod;
    std::vector<ImuSample> imu;
    for (; next_imu <= t; next_imu += kImuPeriod)
      imu.push_back({next_imu, Eigen::Vector3d::Zero(), up_in_camera});
    auto result = rec->track_and_fuse(t, frame.depth, nullptr, imu);
    if (!result) {
      std::fprintf(stderr, "soak: frame %ld: %s\n", i, result.error().describe().c_str());
      return 1;
    }
    if (keep_results) kept.push_back(std::move(*result));
    if (i % every == 0 || i + 1 == frames) {
      at_frame.push_back(static_cast<double>(i));
      rss.push_back(rss_bytes());
      std::printf("%10ld %10.2f\n", i, rss.back() / (1024.0 * 1024.0));
      std::fflush(stdout);
    }
  }
  const std::size_t warm = at_frame.size() / 10 + 1;
  const std::vector<double> x(at_frame.begin() + static_cast<std::ptrdiff_t>(warm), at_frame.end());
  const std::vector<double> y(rss.begin() + static_cast<std::ptrdiff_t>(warm), rss.end());
  std::printf("growth after frame %.0f: %.0f bytes/frame (trajectory: %zu bytes/frame)%s\n",
              at_frame[warm], slope(x, y), sizeof(StampedPose),
              keep_results ? ", FrameResults kept" : "");
  return 0;
}

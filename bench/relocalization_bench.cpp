// Relocalization's translation search on the host (src/core/relocalizer.hpp): the model is the
// own generator's room (seed 1) as seen from 60 poses of its camera path, 1 cm apart at most;
// the frame is one view of it at 80x60 (the coarsest tracking level at 640x480). Wall time of
// building the distance fields and of one search with RelocalizationConfig's defaults:
//   BM_FieldBuild/CELL_MM: a field of the model, cutoff 0.2 m (4 fine cells, as the search's).
//   BM_Search/RADIUS_CM: the search with the gyroscope, 800 points, 5 cm cells.
//   BM_TurnedSweep: the sweep without the gyroscope over 24 turns x 3 tilts, 200 points, 10 cm
//   cells, radius 1.5 m (RelocalizationConfig::max_radius).

#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <numbers>
#include <vector>

#include "core/relocalizer.hpp"
#include "imufusion/synth.hpp"
#include "reference/preprocess_reference.hpp"

namespace imufusion {
namespace {

// The points of a noiseless depth image seen from T at `k` within 0.3-4 m, in the world frame
// (`world`) or the camera's.
std::vector<Eigen::Vector3d> seen_points(const synth::Scene& scene, const Eigen::Isometry3d& T,
                                         const Intrinsics& k, bool world) {
  const Vec4Image vertices = reference::vertex_map(synth::raycast_depth(scene, T, k), k);
  std::vector<Eigen::Vector3d> out;
  for (const Eigen::Vector4f& v : vertices.data) {
    const Eigen::Vector3d p = v.head<3>().cast<double>();
    if (v.w() == 0 || !(p.z() > 0.3 && p.z() < 4.0)) continue;
    out.push_back(world ? Eigen::Vector3d(T * p) : p);
  }
  return out;
}

struct Setup {
  std::vector<Eigen::Vector3d> surface, frame;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
};

const Setup& setup() {
  static const Setup s = [] {
    Setup out;
    const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 1);
    const synth::CameraMotion motion(synth::SceneKind::kRoom, 1);
    const Intrinsics k160 = synth::default_intrinsics(160, 120);
    for (int i = 0; i < 60; ++i) {
      const std::vector<Eigen::Vector3d> seen =
          seen_points(scene, motion.pose_at(0.2 * i), k160, true);
      out.surface.insert(out.surface.end(), seen.begin(), seen.end());
    }
    out.T = motion.pose_at(6.1);
    out.frame = seen_points(scene, out.T, synth::default_intrinsics(80, 60), false);
    return out;
  }();
  return s;
}

void BM_FieldBuild(benchmark::State& state) {
  const double cell = static_cast<double>(state.range(0)) / 1000;
  for (auto _ : state) {
    SurfaceDistanceField field(setup().surface, cell, 4 * 0.05);
    benchmark::DoNotOptimize(field);
  }
  state.counters["surface_points"] = static_cast<double>(setup().surface.size());
}
BENCHMARK(BM_FieldBuild)->Arg(50)->Arg(100)->Unit(benchmark::kMillisecond);

void BM_Search(benchmark::State& state) {
  const Setup& s = setup();
  const SurfaceDistanceField field(s.surface, 0.05, 0.2);
  const std::vector<Eigen::Vector3d> points = spread_subset(s.frame, 800);
  const double radius = static_cast<double>(state.range(0)) / 100;
  const Eigen::Vector3d drift(0.3, -0.2, 0.1);
  double error = 0;
  for (auto _ : state) {
    const auto found = field.search(points, s.T.linear(), s.T.translation() + drift, radius, 3);
    benchmark::DoNotOptimize(found);
    if (!found.empty()) error = (found.front().translation - s.T.translation()).norm();
  }
  state.counters["points"] = static_cast<double>(points.size());
  state.counters["best_error_m"] = error;
}
BENCHMARK(BM_Search)->Arg(30)->Arg(80)->Arg(150)->Unit(benchmark::kMillisecond);

void BM_TurnedSweep(benchmark::State& state) {
  const Setup& s = setup();
  const SurfaceDistanceField coarse(s.surface, 0.1, 0.2);
  const std::vector<Eigen::Vector3d> few = spread_subset(s.frame, 200);
  const double step = 15 * std::numbers::pi / 180;
  const Eigen::Vector3d up = s.T.linear().col(1), side = s.T.linear().col(0);
  std::vector<Eigen::Matrix3d> orientations;
  for (int turn = 0; turn < 24; ++turn)
    for (int tilt = -1; tilt <= 1; ++tilt)
      orientations.push_back(
          (Eigen::AngleAxisd(turn * step, up) * Eigen::AngleAxisd(tilt * step, side))
              .toRotationMatrix() *
          s.T.linear());
  for (auto _ : state)
    for (const Eigen::Matrix3d& R : orientations) {
      const auto found = coarse.search(few, R, s.T.translation(), 1.5, 6);
      benchmark::DoNotOptimize(found);
    }
  state.counters["orientations"] = static_cast<double>(orientations.size());
}
BENCHMARK(BM_TurnedSweep)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace imufusion

BENCHMARK_MAIN();

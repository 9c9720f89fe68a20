// ICP at 640x480 on two synthetic room frames 1/30 s apart: wall time of one track() (both
// frames' preprocessing excluded from the GPU kernel counters, included in the wall time), GPU
// time per association and per reduction at each pyramid level (mean per iteration), and
// iterations run. Args: iteration cap (30: the no-IMU setting, 1: the paper's IMU setting).

#include <benchmark/benchmark.h>

#include <map>
#include <string>

#include "imufusion/icp.hpp"
#include "imufusion/synth.hpp"

namespace imufusion {
namespace {

void BM_Icp640x480(benchmark::State& state) {
  const Intrinsics k = synth::default_intrinsics(640, 480);
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 1);
  const synth::CameraMotion motion(synth::SceneKind::kRoom, 1);
  const Eigen::Isometry3d T_w_ref = motion.pose_at(2.0), T_w_cur = motion.pose_at(2.0 + 1.0 / 30);
  const DepthImage ref = synth::render_depth(scene, T_w_ref, k, {}, 1);
  const DepthImage cur = synth::render_depth(scene, T_w_cur, k, {}, 2);
  IcpConfig config;
  config.max_total_iterations = static_cast<int>(state.range(0));
  auto tracker = IcpTracker::create(config, PreprocessConfig{}, k);
  if (!tracker || !tracker->set_reference(ref).ok()) {
    state.SkipWithError("no device");
    return;
  }
  // With one iteration the start is the IMU-like seed (truth within ~0.5 deg / 5 mm).
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  if (config.max_total_iterations == 1) {
    Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
    offset.linear() =
        Eigen::AngleAxisd(0.5 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
    offset.translation() = Eigen::Vector3d(0.005, 0, 0);
    start = T_w_ref.inverse() * T_w_cur * offset;
  }
  std::map<std::string, std::pair<double, int>> per_kernel;  // total ms, dispatches
  double iterations = 0;
  for (auto _ : state) {
    std::vector<KernelTiming> timings;
    auto result = tracker->track(cur, start, &timings);
    if (!result) {
      state.SkipWithError(result.error().describe().c_str());
      return;
    }
    iterations += result->quality.iterations;
    for (const KernelTiming& t : timings) {
      if (t.kernel.rfind("icp_", 0) != 0) continue;
      per_kernel[t.kernel].first += t.gpu_ms;
      per_kernel[t.kernel].second += 1;
    }
  }
  double icp_gpu_ms = 0;
  for (const auto& [kernel, v] : per_kernel) {
    state.counters[kernel + "_ms"] = v.first / v.second;  // per dispatch (= per iteration)
    icp_gpu_ms += v.first;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["iterations"] = iterations / n;
  state.counters["icp_gpu_ms_per_frame"] = icp_gpu_ms / n;
  state.SetLabel(tracker->device().name);
}

BENCHMARK(BM_Icp640x480)->Arg(30)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(3.0);

}  // namespace
}  // namespace imufusion

BENCHMARK_MAIN();

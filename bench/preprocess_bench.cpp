// GPU depth preprocessing at 640x480 on a synthetic room frame: wall time per frame (upload,
// kernels, download) and each kernel's GPU time (timestamp queries) as counters, for several
// workgroup sizes. Device: IMUFUSION_DEVICE or the default choice.

#include <benchmark/benchmark.h>

#include <map>
#include <string>

#include "imufusion/preprocess.hpp"
#include "imufusion/synth.hpp"

namespace imufusion {
namespace {

const DepthImage& room_frame() {
  static const DepthImage depth = [] {
    const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 1);
    const synth::CameraMotion motion(synth::SceneKind::kRoom, 1);
    return synth::render_depth(scene, motion.pose_at(2.0), synth::default_intrinsics(640, 480),
                               synth::SensorModel{}, 1);
  }();
  return depth;
}

void BM_Preprocess640x480(benchmark::State& state) {
  PreprocessConfig config;
  config.workgroup_x = static_cast<int>(state.range(0));
  config.workgroup_y = static_cast<int>(state.range(1));
  auto pre = DepthPreprocessor::create(config, synth::default_intrinsics(640, 480));
  if (!pre) {
    state.SkipWithError(pre.error().describe().c_str());
    return;
  }
  const DepthImage& depth = room_frame();
  std::map<std::string, double> gpu_ms;
  double total_gpu_ms = 0;
  for (auto _ : state) {
    auto frame = pre->process(depth);
    if (!frame) {
      state.SkipWithError(frame.error().describe().c_str());
      return;
    }
    for (const KernelTiming& t : frame->timings) {
      gpu_ms[t.kernel] += t.gpu_ms;
      total_gpu_ms += t.gpu_ms;
    }
  }
  const double n = static_cast<double>(state.iterations());
  for (const auto& [kernel, ms] : gpu_ms) state.counters[kernel + "_ms"] = ms / n;
  state.counters["all_kernels_ms"] = total_gpu_ms / n;
  state.SetLabel(pre->device().name);
}

BENCHMARK(BM_Preprocess640x480)
    ->Args({16, 16})
    ->Args({8, 8})
    ->Args({32, 8})
    ->Args({64, 1})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

}  // namespace
}  // namespace imufusion

BENCHMARK_MAIN();

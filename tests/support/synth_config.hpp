#pragma once
// The small synthetic sequences the tests render: a scene, a seed and a length, at 160x120
// unless told otherwise (the rest are imufusion-synth's defaults).

#include <cstdint>

#include "imufusion/synth.hpp"

namespace imufusion::test {

inline synth::SynthConfig small_synth_config(synth::SceneKind scene, std::uint64_t seed, int frames,
                                             int width = 160, int height = 120) {
  synth::SynthConfig config;
  config.scene = scene;
  config.seed = seed;
  config.frames = frames;
  config.width = width;
  config.height = height;
  return config;
}

}  // namespace imufusion::test

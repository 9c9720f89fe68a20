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

// A wall 1 m ahead of the identity camera (facing +z), checkered in two colours of 5 cm squares:
// its depth leaves the motion along it free, its colour does not.
inline synth::Scene checkered_wall() {
  synth::Plane wall;
  wall.normal = Eigen::Vector3d(0, 0, 1);
  wall.offset = 1.0;
  wall.material.color = Eigen::Vector3f(0.15f, 0.2f, 0.25f);
  wall.material.color2 = Eigen::Vector3f(0.9f, 0.85f, 0.8f);
  wall.material.checker_size = 0.05;
  synth::Scene scene;
  scene.planes.push_back(wall);
  return scene;
}

}  // namespace imufusion::test

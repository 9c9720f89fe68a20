#pragma once
// The embedded demo scan: the synthetic furnished room with a phone-like IMU, synthesized on the
// first run into a directory and reused while it is complete.

#include <filesystem>
#include <iostream>

#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"

namespace imufusion::tools {

inline Result<std::filesystem::path> ensure_demo_sequence(const std::filesystem::path& dir,
                                                          int frames) {
  if (auto existing = SequenceReader::open(dir); existing.ok()) {
    const auto& info = existing->info().info;
    auto source = info.find("source");
    if (source != info.end() && source->second.find("imufusion-synth") != std::string::npos &&
        existing->frame_count() == static_cast<std::size_t>(frames)) {
      return dir;
    }
  }
  synth::SynthConfig config;
  config.scene = synth::SceneKind::kRoom;
  config.frames = frames;
  config.overwrite = true;
  std::cerr << "synthesizing the demo room scan (" << config.frames << " frames, " << config.width
            << "x" << config.height << ") into " << dir.string() << " ...\n";
  auto summary = synth::synthesize(config, dir);
  if (!summary) return summary.error();
  return dir;
}

}  // namespace imufusion::tools

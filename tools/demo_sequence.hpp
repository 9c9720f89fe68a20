#pragma once
// The embedded demo scan: the synthetic furnished room with a phone-like IMU, seen by the
// generator's model of the preset's sensor, synthesized on the first run into a directory and
// reused while it is complete.

#include <filesystem>
#include <iostream>
#include <string>

#include "imufusion/presets.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"

namespace imufusion::tools {

inline synth::SensorKind demo_sensor(SensorPreset sensor) {
  return sensor == SensorPreset::kPhoneToF ? synth::SensorKind::kPhoneToF
                                           : synth::SensorKind::kKinect;
}

inline Result<std::filesystem::path> ensure_demo_sequence(const std::filesystem::path& dir,
                                                          int frames, SensorPreset sensor) {
  const synth::SensorKind kind = demo_sensor(sensor);
  if (auto existing = SequenceReader::open(dir); existing.ok()) {
    const auto& info = existing->info().info;
    auto source = info.find("source");
    auto written_sensor = info.find("sensor");  // absent: the Kinect model
    const std::string sensor_name =
        written_sensor == info.end() ? "kinect" : written_sensor->second;
    // A demo written before the disparity noise model has no depth_noise_model line.
    const bool current_noise = info.count("depth_noise_model") != 0;
    if (source != info.end() && source->second.find("imufusion-synth") != std::string::npos &&
        existing->frame_count() == static_cast<std::size_t>(frames) &&
        sensor_name == synth::to_string(kind) && current_noise) {
      return dir;
    }
  }
  synth::SynthConfig config;
  config.scene = synth::SceneKind::kRoom;
  config.sensor = kind;
  const synth::SensorFormat format = synth::sensor_format(kind);
  config.width = format.width;
  config.height = format.height;
  config.fps = format.fps;
  config.frames = frames;
  config.overwrite = true;
  std::cerr << "synthesizing the demo room scan (" << config.frames << " frames, " << config.width
            << "x" << config.height << ") into " << dir.string() << " ...\n";
  auto summary = synth::synthesize(config, dir);
  if (!summary) return summary.error();
  return dir;
}

}  // namespace imufusion::tools

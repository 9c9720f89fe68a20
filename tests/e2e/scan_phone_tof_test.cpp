// imufusion-scan --sensor phone-tof on a short sequence of the generator's phone ToF model
// (240x180, 1 % of depth noise, flying pixels): the preset tracks every frame to a few
// millimetres, with and without the IMU, where the Kinect preset on the same frames loses them
// without the IMU (its depth noise, a fifth of the ToF model's at 1 m, rejects most pairs as too
// far off-normal; with the IMU it keeps them, pairing 26 % of the pixels against the ToF
// preset's 60 %).

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "../support/synth_config.hpp"
#include "imufusion/synth.hpp"
#include "scan_test_fixtures.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

class ScanPhoneToF : public test::ScanToolTest {
 protected:
  ScanPhoneToF() : ScanToolTest("imufusion_scan_tof_") {}

  // The fast scene (bursts of 90 deg/s) seen by the phone ToF model at its 240x180.
  fs::path synthesize_tof(int frames, std::uint64_t seed) {
    synth::SynthConfig config = test::small_synth_config(synth::SceneKind::kFast, seed, frames);
    config.sensor = synth::SensorKind::kPhoneToF;
    const synth::SensorFormat format = synth::sensor_format(config.sensor);
    config.width = format.width;
    config.height = format.height;
    const fs::path dir = path("tof");
    auto summary = synth::synthesize(config, dir);
    EXPECT_TRUE(summary.ok()) << summary.error().describe();
    return dir;
  }

  // Runs the scan; returns summary.json.
  nlohmann::json scan_with(const fs::path& seq, const std::string& args, const std::string& out) {
    const auto run = scan(seq.string() + " --out " + path(out).string() + " --quiet " + args);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return test::read_json(path(out) / "summary.json");
  }
};

TEST_F(ScanPhoneToF, ThePresetTracksEveryFrameWhereTheKinectPresetLosesThem) {
  const fs::path seq = synthesize_tof(40, 21);
  for (const std::string imu : {"", "--no-imu"}) {
    const nlohmann::json tof = scan_with(seq, "--sensor phone-tof " + imu, "tof" + imu);
    EXPECT_EQ(tof["frames_fused"].get<double>(), 40.0) << imu;
    EXPECT_LT(tof["ate"]["rmse"].get<double>(), 0.005) << imu << tof["ate"].dump();
  }
  const nlohmann::json kinect = scan_with(seq, "--sensor kinect --no-imu", "kinect");
  EXPECT_LT(kinect["frames_fused"].get<double>(), 20.0);
  EXPECT_GT(kinect["ate"]["rmse"].get<double>(), 0.05) << kinect["ate"].dump();
}

TEST_F(ScanPhoneToF, AnUnknownSensorIsRefusedNamingIt) {
  const auto run = scan("--sensor kinect2 --out " + path("out").string());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("kinect2"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("phone-tof"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace imufusion

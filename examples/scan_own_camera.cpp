// A scanning app's loop: create the scanner, feed each depth frame (raw 16-bit depth) with the IMU
// samples that came since the previous one, handle the tracking status, finish, write the mesh,
// the trajectory and a preview. A recorded sequence directory stands in for the camera
// (imufusion-synth --scene room --out DIR writes one).
//   scan_own_camera SEQUENCE_DIR OUT_DIR
#include <filesystem>
#include <imufusion/image_io.hpp>
#include <imufusion/mesh.hpp>
#include <imufusion/presets.hpp>
#include <imufusion/reconstructor.hpp>
#include <imufusion/sequence.hpp>
#include <imufusion/trajectory.hpp>
#include <iostream>

using namespace imufusion;

static int fail(const Error& error) {
  std::cerr << "scan_own_camera: " << error.describe() << "\n";
  return 1;
}

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: scan_own_camera SEQUENCE_DIR OUT_DIR\n";
    return 2;
  }
  auto camera = SequenceReader::open(argv[1]);
  if (!camera) return fail(camera.error());
  if (!camera->intrinsics()) return fail({ErrorCode::kNotFound, "no calibration.txt"});

  // What the app knows about its sensor: its class (the preset), the depth camera's intrinsics
  // (pixels), whether it has an IMU and where it sits (T_camera_imu maps IMU coordinates into
  // the camera frame; leave it unknown and the scanner estimates the rotation).
  ReconstructorConfig config =
      preset_config(SensorPreset::kKinect, *camera->intrinsics(), camera->has_imu());
  config.inertial.T_camera_imu = camera->T_camera_imu();
  config.inertial.T_camera_imu_known = camera->info().has_imu_to_camera;
  auto scanner = Reconstructor::create(config);
  if (!scanner) return fail(scanner.error());

  std::size_t lost = 0;
  while (!camera->done()) {
    auto frame = camera->next();  // DepthImage: width, height, units per metre, uint16 pixels
    if (!frame) return fail(frame.error());
    const ColorImage* color = frame->color ? &*frame->color : nullptr;
    auto result = scanner->track_and_fuse(frame->timestamp, frame->depth, color, frame->imu);
    if (!result) return fail(result.error());  // a wrong-sized frame, a lost device
    // Lost tracking is a status: the pose is dead-reckoned and nothing is fused until the
    // camera finds the model again.
    if (result->status == TrackingStatus::kLost) {
      ++lost;
      std::cout << "frame " << result->index << ": lost, pose from " << to_string(result->source)
                << "\n";
    }
  }
  if (auto settled = scanner->finish(); !settled) return fail(settled.error());
  if (scanner->trajectory().empty()) return fail({ErrorCode::kNotFound, "no depth frames"});

  const std::filesystem::path out = argv[2];
  std::filesystem::create_directories(out);
  auto mesh = scanner->extract_mesh();
  if (!mesh) return fail(mesh.error());
  if (auto s = write_ply(out / "mesh.ply", *mesh); !s) return fail(s.error());
  if (auto s = write_trajectory(out / "trajectory.txt", scanner->trajectory()); !s) {
    return fail(s.error());
  }
  auto view = scanner->raycast(scanner->trajectory().back().T_world_camera);
  if (!view) return fail(view.error());
  if (auto s = write_color_png(out / "preview.png", view->shaded); !s) return fail(s.error());
  std::cout << scanner->trajectory().size() << " frames, " << lost << " lost; mesh of "
            << mesh->vertices.size() << " vertices, " << mesh->triangles.size() << " triangles in "
            << (out / "mesh.ply").string() << "\n";
  return 0;
}

#pragma once
// Synthetic RGB-D + IMU sequences with exact ground truth, rendered on the CPU from analytic
// scenes, so that tests and demos need no downloaded data.
//
// World frame: z up, metres. The default room spans [0, 6] x [0, 5] x [0, 3] (x east, y north,
// floor at z = 0). Camera frame: x right, y down, z forward (optical axis). IMU frame: a phone
// frame (x right, y up, z toward the user) mounted with a few degrees of error and a small lever
// arm; `T_camera_imu` maps IMU coordinates into the camera frame.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string_view>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion::synth {

/// `room`: a furnished room. `wall`: the room with a ~2 s stretch facing a bare wall at ~1 m
/// while moving; the walk around the room pauses for the episode, so the camera turns back to
/// the part of the room it left (the scan can only recover onto what it has scanned). `fast`: the
/// room with bursts of ~90 deg/s rotation and faster walking.
enum class SceneKind { kRoom, kWall, kFast };

const char* to_string(SceneKind kind);
/// "room", "wall" or "fast"; nullopt for anything else.
std::optional<SceneKind> parse_scene_kind(std::string_view name);

/// Surface colour (linear RGB in [0, 1]). With `checker_size` > 0 (metres) the surface is a
/// checkerboard of `color` and `color2` laid out in the two world axes most parallel to it.
struct Material {
  Eigen::Vector3f color = Eigen::Vector3f(0.7f, 0.7f, 0.7f);
  Eigen::Vector3f color2 = Eigen::Vector3f(0.7f, 0.7f, 0.7f);
  double checker_size = 0.0;
};

/// The inside of an axis-aligned box (floor, ceiling, four walls), seen from within.
struct RoomShell {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d(6.0, 5.0, 3.0);
  Material floor, ceiling;
  Material walls[4];  // x = min.x, x = max.x, y = min.y, y = max.y
};

/// A solid box rotated by `yaw` (radians, about world z) around its centre.
struct Box {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_extents = Eigen::Vector3d::Constant(0.5);
  double yaw = 0.0;
  Material material;
};

/// A solid cylinder with a vertical axis through `center_xy`, capped at z_min and z_max.
struct Cylinder {
  Eigen::Vector2d center_xy = Eigen::Vector2d::Zero();
  double radius = 0.5, z_min = 0.0, z_max = 1.0;
  Material material;
};

struct Sphere {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius = 0.5;
  Material material;
};

/// An infinite two-sided plane {x : normal . x = offset}; `normal` must be unit length.
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double offset = 0.0;
  Material material;
};

/// Plain data: tests may build their own scenes (e.g. one plane) as well as use make_scene().
struct Scene {
  std::optional<RoomShell> room;
  std::vector<Box> boxes;
  std::vector<Cylinder> cylinders;
  std::vector<Sphere> spheres;
  std::vector<Plane> planes;
};

/// The furnished room (the same furniture for every kind; the x = max wall is kept bare between
/// y = 1.0 and y = 4.0 m for the wall stretch). `seed` varies colours only, never geometry.
Scene make_scene(SceneKind kind, std::uint64_t seed);

/// The nearest surface along a ray. Primitive ids: 0 the room, then boxes, cylinders, spheres,
/// planes in order (so two pixels on the same id lie on one smooth or convex surface).
struct RayHit {
  double t = 0.0;                                    // ray parameter: point = origin + t * dir
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   // world, metres
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // world, unit, facing the ray origin
  Eigen::Vector3f albedo = Eigen::Vector3f::Zero();  // material colour at the point
  int primitive = -1;
};

/// Exact ray cast; `direction` need not be unit length. Hits with t <= 1e-9 are ignored.
std::optional<RayHit> intersect(const Scene& scene, const Eigen::Vector3d& origin,
                                const Eigen::Vector3d& direction);

/// Euclidean distance (metres) from `point` to the nearest surface of any primitive: the room's
/// six faces, box and cylinder boundaries (caps included), spheres, planes. Parts of a surface
/// hidden inside another primitive count too. +infinity for an empty scene.
double distance_to_surface(const Scene& scene, const Eigen::Vector3d& point);

/// Default Kinect-like intrinsics (640x480: fx = fy = 525, cx = 319.5, cy = 239.5) scaled to
/// width x height (fx by width / 640, fy by height / 480, pixel centres kept consistent).
Intrinsics default_intrinsics(int width = 640, int height = 480);

/// The depth sensors the generator models.
enum class SensorKind {
  /// Kinect v1 structured light: depth from a disparity quantized to 1/8 px, its error shared
  /// over the block-matching window, Kinect v1 noise (depth_noise_sigma), no depth next to depth
  /// edges, 0.4-4.5 m.
  kKinect,
  /// A phone time-of-flight module of 2019-2021 phones (240x180 at 30 Hz, Sony IMX316 class,
  /// Android DEPTH16: millimetre steps, 13 bits): noise as tof_noise_sigma, flying pixels at
  /// depth edges, no depth where the returned amplitude is weak, 0.2-4 m.
  kPhoneToF,
};

/// "kinect" or "phone-tof".
const char* to_string(SensorKind kind);
/// The kind named `name` (as to_string writes it); nullopt for anything else.
std::optional<SensorKind> parse_sensor_kind(std::string_view name);

/// The depth sensor model applied by render_depth(); sensor_model() gives each kind's values.
struct SensorModel {
  SensorKind kind = SensorKind::kKinect;  // which noise and depth-edge model applies
  /// Axial noise: Kinect sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2 m in all (disparity steps
  /// included); phone ToF tof_noise_sigma(z, reflectance, cos incidence). false: the exact depth
  /// in 1 / depth_scale steps, no disparity steps.
  bool depth_noise = true;
  /// Kinect: no depth next to depth discontinuities (one pixel each side). Phone ToF: such a
  /// pixel is a flying pixel (kFlyingPixelShare) or has no depth.
  bool edge_dropout = true;
  double max_incidence_deg = 78.0;          // no depth where the surface is seen more obliquely
  double min_depth = 0.4, max_depth = 4.5;  // metres along the optical axis, 0 outside
  double depth_scale = 5000.0;              // raw units per metre (quantization 1/5000 m)
  /// Kinect: disparity d = baseline_focal / z, px at the IR camera's 640x480 (7.5 cm x 580 px).
  double baseline_focal = 43.5;
  /// Kinect: disparity steps, px (the sensor's 1/8 px: 2.9 mm of depth at 1 m, 11.5 at 2 m);
  /// 0: depth steps of 1 / depth_scale only.
  double disparity_step = 0.125;
  /// Kinect: the noise is white noise averaged over this window, px at 640x480 (scaled to the
  /// image; block matching shares a pixel's error with its neighbours); 1: independent pixels.
  int noise_window = 9;
  /// 1/m^2: no depth where reflectance * cos(incidence) / z^2, the returned amplitude relative
  /// to a white surface at 1 m, is below this (a ToF camera's low-confidence pixels). 0: off.
  double min_amplitude = 0.0;
};

/// The model of `kind`: SensorModel's defaults for kKinect; for kPhoneToF 0.2-4 m, 1/1000 m
/// steps, min_amplitude 0.02 (a grey surface, reflectance 0.5, head-on to 5 m).
SensorModel sensor_model(SensorKind kind);

/// `model` with independent per-pixel noise and no disparity steps (noise_window 1,
/// disparity_step 0): the Kinect model before disparity quantization.
SensorModel white_noise_model(SensorModel model);

/// Image size (px) and frame rate (Hz) the kind delivers: 640x480 at 30 Hz for kKinect,
/// 240x180 at 30 Hz for kPhoneToF (the DEPTH16 stream of IMX316-class phones).
struct SensorFormat {
  int width = 640, height = 480;
  double fps = 30.0;
};
SensorFormat sensor_format(SensorKind kind);

/// Axial depth noise standard deviation of a Kinect v1 (Nguyen et al. 2012), metres: the total
/// error, disparity steps included.
double depth_noise_sigma(double z);

/// The depth step (metres) at depth z of a disparity quantized to `model.disparity_step`:
/// z^2 disparity_step / baseline_focal; 0 when disparity_step is 0.
double disparity_depth_step(double z, const SensorModel& model);

/// Axial depth noise of the phone ToF model, metres: 1 % of z on a surface of reflectance 0.5
/// (mean albedo) seen head-on, the error Sony states for its DepthSense IMX316/IMX516 sensors;
/// it scales as 1 / sqrt(reflectance * cos(incidence)), the shot noise of the returned amplitude
/// (Lange and Seitz, IEEE J. Quantum Electron. 2001). The product is floored at 0.01.
double tof_noise_sigma(double z, double reflectance, double cos_incidence);

/// Phone ToF: the share of depth-edge pixels that are flying pixels, their depth a mix of both
/// surfaces' (the far surface's weight uniform in [0, 0.5]: the pixel's centre lies on its own
/// surface); the others have no depth (the phone's confidence filter; Hansard et al.,
/// "Time-of-Flight Cameras", Springer 2012, ch. 1 on mixed pixels).
inline constexpr double kFlyingPixelShare = 0.5;

/// Noiseless z-depth (metres along the optical axis) of every pixel, 0 where no surface is hit.
/// No sensor model: no range limits, no dropouts, no quantization beyond float.
FloatImage raycast_depth(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                         const Intrinsics& intrinsics);

/// A 16-bit depth image through the sensor model. The same (scene, pose, model, seed) gives the
/// same image; noise does not depend on the number of render threads.
DepthImage render_depth(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                        const Intrinsics& intrinsics, const SensorModel& model, std::uint64_t seed);

/// A colour image registered to the depth image (Lambertian shading, one light near the ceiling).
ColorImage render_color(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                        const Intrinsics& intrinsics);

struct RenderedFrame {
  DepthImage depth;
  ColorImage color;  // empty (0 x 0) when not requested
};

/// Depth and (optionally) colour from one ray cast.
RenderedFrame render_frame(const Scene& scene, const Eigen::Isometry3d& T_world_camera,
                           const Intrinsics& intrinsics, const SensorModel& model,
                           std::uint64_t seed, bool with_color);

/// A closed time interval, seconds on the sequence clock.
struct TimeSpan {
  double begin = 0.0, end = 0.0;
};

/// A smooth hand-held camera path through the room (sums of sinusoids around an orbit of the
/// furniture at walking speed, ~0.3 m/s; 0.6 m/s with rotation bursts for `fast`), defined for
/// every t and deterministic from the seed. Time 0 of the path is `start_time`.
class CameraMotion {
 public:
  CameraMotion(SceneKind kind, std::uint64_t seed, double start_time = 0.0);

  /// Ground truth T_world_camera at time t (seconds).
  Eigen::Isometry3d pose_at(double t) const;

  /// For `wall`: the interval during which only the bare wall (x = 6 m plane) is in view:
  /// start_time + [4.0, 6.0] s, after a 3.5 s turn from the room (so 180 frames at 30 fps
  /// reach its end; the turn back ends at 9.5 s, 285 frames).
  std::optional<TimeSpan> wall_stretch() const;

  /// The smallest duration (seconds from start_time) that contains the whole wall episode:
  /// turn to the wall, the stretch, and the turn back. 0 for other kinds.
  double episode_end() const;

  SceneKind kind() const { return kind_; }
  double start_time() const { return start_time_; }

  struct Wave {
    double amplitude = 0.0, frequency_hz = 0.0, phase = 0.0;
    double at(double tau) const;
  };

 private:
  struct LookPose {
    Eigen::Vector3d position;
    double yaw = 0, pitch = 0, roll = 0;  // radians; yaw about world z from +x, pitch up
  };
  /// Time along the orbit: tau, except that for `wall` the orbit eases to a stop as the turn
  /// to the wall begins and resumes as the turn back ends.
  double orbit_time(double tau) const;
  LookPose orbit_pose(double tau) const;
  LookPose wall_pose(double tau) const;
  LookPose look_pose(double tau) const;

  SceneKind kind_;
  double start_time_;
  double direction_ = 1.0;      // +1 counter-clockwise orbit seen from above, -1 clockwise
  double phase0_ = 0.0;         // orbit angle at tau = 0 (radians)
  double speed_ = 0.3;          // m/s along the orbit
  Wave position_jitter_[3][2];  // hand shake, metres, per world axis
  Wave angle_jitter_[3][2];     // yaw, pitch, roll shake, radians
  Wave target_wander_[3];       // where the person looks, metres
  Wave speed_wave_;             // walking speed modulation (fraction)
};

/// The IMU mounting: a phone frame (x right, y up, z toward the user) rotated by a few degrees
/// of mounting error, with a 2-3 cm lever arm. Maps IMU coordinates into the camera frame.
Eigen::Isometry3d default_T_camera_imu();

struct ImuConfig {
  double rate_hz = 200.0;
  double gyro_noise_density = 0.003;  // rad/s/sqrt(Hz), white noise
  double accel_noise_density = 0.01;  // m/s^2/sqrt(Hz), white noise
  bool noise = true;                  // white noise on both sensors
  bool bias = true;                   // constant biases (drawn from the seed)
  double timestamp_jitter = 0.0005;   // seconds, uniform +-, timestamps stay increasing
  Eigen::Isometry3d T_camera_imu = default_T_camera_imu();
};

/// Constant sensor biases: gyro per axis 0.01-0.02 rad/s with random sign, accelerometer per
/// axis 0.02-0.06 m/s^2 with random sign.
struct ImuBias {
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // rad/s, IMU frame
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // m/s^2, IMU frame
};
ImuBias draw_imu_bias(std::uint64_t seed);

/// Standard gravity in the world frame (z up), m/s^2.
inline Eigen::Vector3d gravity_world() { return Eigen::Vector3d(0.0, 0.0, -9.81); }

/// True angular velocity of the IMU body at t, in the IMU frame (rad/s).
Eigen::Vector3d true_gyro(const CameraMotion& motion, const Eigen::Isometry3d& T_camera_imu,
                          double t);
/// True specific force R_imu_world (a_world - g_world) at t, in the IMU frame (m/s^2); +9.81
/// along the IMU's up direction at rest. Includes the lever-arm acceleration.
Eigen::Vector3d true_accel(const CameraMotion& motion, const Eigen::Isometry3d& T_camera_imu,
                           double t);

/// Samples at `rate_hz` (jittered stamps) from t_begin to t_end: true values + bias + noise.
std::vector<ImuSample> generate_imu(const CameraMotion& motion, const ImuConfig& config,
                                    const ImuBias& bias, double t_begin, double t_end,
                                    std::uint64_t seed);

/// A whole sequence on disk.
struct SynthConfig {
  SceneKind scene = SceneKind::kRoom;
  std::uint64_t seed = 1;
  int width = 640, height = 480;
  int frames = 300;
  double fps = 30.0;
  double imu_rate = 200.0;
  bool color = true;
  bool depth_noise = true;  // depth noise (range limits, dropouts, 1/depth_scale steps stay)
  /// Kinect: independent noise per pixel and depth steps of 1/5000 m only (SensorModel
  /// noise_window 1, disparity_step 0) instead of the disparity model.
  bool white_depth_noise = false;
  /// The depth sensor's model (sensor_model()); width, height and fps are set on their own
  /// (sensor_format() gives the kind's).
  SensorKind sensor = SensorKind::kKinect;
  bool imu_noise = true;              // IMU white noise and biases
  double gyro_noise_density = 0.003;  // rad/s/sqrt(Hz)
  double accel_noise_density = 0.01;  // m/s^2/sqrt(Hz)
  double start_time = 1000.0;         // clock of the first depth frame, seconds
  bool overwrite = false;             // replace an existing non-empty out_dir
};

struct SynthSummary {
  int frames = 0;
  double duration = 0.0;  // seconds from the first to the last depth frame
  int width = 0, height = 0;
  std::size_t imu_samples = 0;
  ImuBias bias;
  std::optional<TimeSpan> wall_stretch;
};

/// Writes the sequence in the FORMAT.md layout (depth/, rgb/, depth.txt, rgb.txt,
/// calibration.txt, imu.txt, imu_to_camera.txt, groundtruth.txt at every depth frame, info.txt).
/// Everything is written into "<out_dir>.partial" first and renamed at the end, so an
/// interrupted run never leaves a complete-looking sequence. Same config -> identical bytes.
Result<SynthSummary> synthesize(const SynthConfig& config, const std::filesystem::path& out_dir);

}  // namespace imufusion::synth

#pragma once
// Rigid point-to-plane ICP on weighted projective correspondences, as in KinectFusion and in
// Niessner, Dai and Fisher (2014): the GPU reduces the normal equations, the host solves the 6x6
// system by SVD, iterates coarse to fine, and judges the result from r, n, sum(w) and kappa.
//
// Frames: the current frame's camera is "cur", the reference's (the previous frame, or the
// model raycast at a predicted pose) is "ref". ICP estimates T_ref_cur (cur -> ref coordinates).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "imufusion/device.hpp"
#include "imufusion/preprocess.hpp"
#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

/// Axial depth noise of the sensor, sigma(z) = a + b (z - z0)^2 metres (Kinect-like default:
/// Nguyen, Izadi and Lovell 2012, also imufusion's synthetic sensor).
struct DepthNoiseModel {
  double a = 0.0012, b = 0.0019, z0 = 0.4;
  double sigma(double z) const { return a + b * (z - z0) * (z - z0); }
  /// A current pixel's share in the inlier fraction: its inverse noise variance relative to the
  /// least noise, (a / sigma(z))^2 in (0, 1]; 1 everywhere when a = 0.
  double information(double z) const {
    const double s = sigma(z);
    return a > 0 ? (a / s) * (a / s) : 1.0;
  }
  /// Mean sigma(z)^2 (m^2) over the depths of `depth` in [min_depth, max_depth] (m); 0 when none.
  double mean_variance(const DepthView& depth, double min_depth, double max_depth) const;
};

/// The normal-angle test of a pair follows the current pixel's depth noise: at depth z a pair is
/// kept up to max(the level's max_normal_angle_deg, atan(noise_k sigma(z) f / z)) (f: focal
/// length in pixels at the level), never beyond max_angle_deg. noise_k: the normals' angular
/// noise in units of sigma(z) over one pixel's footprint (bench/normal_noise; default 0.5);
/// 0: the level's angle alone.
struct NormalGate {
  double noise_k = 0.5;
  double max_angle_deg = 60;
};

/// The weighted normal equations of one association pass (sums over accepted pairs):
/// AtA = sum w a a^T, Atb = sum w a b, btb = sum w b^2 (m^2), inliers = number of pairs,
/// weight_sum = sum w. valid_pixels counts the current pixels with a vertex and a normal;
/// valid_information and inlier_information sum DepthNoiseModel::information of the current
/// frame's depth over those pixels and over those paired; uncovered_pixels and
/// uncovered_information count those valid pixels that the reference does not cover (their
/// projection falls behind the camera, outside its image or where it has no surface).
struct NormalEquations {
  Eigen::Matrix<double, 6, 6> AtA = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> Atb = Eigen::Matrix<double, 6, 1>::Zero();
  double btb = 0;
  std::uint64_t inliers = 0;
  double weight_sum = 0;
  std::uint64_t valid_pixels = 0;
  double valid_information = 0;
  double inlier_information = 0;
  std::uint64_t uncovered_pixels = 0;
  double uncovered_information = 0;
  /// A photometric term (add_photometric), in the depth's units: the solve adds it to AtA and
  /// Atb; kappa, the residual, the pairing figures and the weights stay the depth's alone.
  Eigen::Matrix<double, 6, 6> photometric_AtA = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> photometric_Atb = Eigen::Matrix<double, 6, 1>::Zero();
  std::uint64_t photometric_pairs = 0;

  /// The system the step solves: the depth's and the photometric term's together.
  Eigen::Matrix<double, 6, 6> system_AtA() const { return AtA + photometric_AtA; }
  Eigen::Matrix<double, 6, 1> system_Atb() const { return Atb + photometric_Atb; }

  /// The paired share of the valid pixels, each counted by its information (0 when none).
  double inlier_fraction() const {
    return valid_information > 0 ? inlier_information / valid_information : 0;
  }
  /// The paired share of the valid pixels, each counting one (0 when none).
  double pixel_fraction() const {
    return valid_pixels > 0 ? double(inliers) / double(valid_pixels) : 0;
  }
  /// The share of the valid pixels' information that the reference covers (0 when none).
  double covered_fraction() const {
    return valid_information > 0 ? 1 - uncovered_information / valid_information : 0;
  }
  /// The paired share of the covered pixels, each counted by its information (0 when none).
  double covered_inlier_fraction() const {
    const double covered = valid_information - uncovered_information;
    return covered > 0 ? inlier_information / covered : 0;
  }
};

/// Adds the photometric equations `photo` (intensity residuals, IcpPhotometricConfig) to the
/// depth's `eq` as its photometric term, each term weighed by the inverse of its own mean squared
/// residual at the pose both were evaluated at: photo scaled by weight * (btb / weight_sum) of
/// `eq`, at least `min_depth_variance` (m^2, the sensor's least noise), over that of `photo`, at
/// least `min_photometric_variance` (intensity^2, the camera's least noise). Nothing is added
/// when the photometric term has no residual.
void add_photometric(NormalEquations& eq, const NormalEquations& photo, double weight,
                     double min_depth_variance = 0, double min_photometric_variance = 0);

/// Thresholds of the reliable / unreliable decision, measured with bench/icp_calibration on 1080
/// synthetic pairs (room, wall and fast scenes, 12 seeds, three kinds of start; recall of good
/// pairs and precision on half of the seeds, checked on the other half) and on whole wall scans
/// (bench/README.md). With these defaults: precision 0.985 / 0.991 (calibration / held-out seeds),
/// recall 1.000 / 0.991. The search's own choice, kappa <= 237, reaches 0.99 precision on the
/// pairs but, like kappa <= 316, moves where whole wall scans lose the wall and made some of them
/// end several centimetres worse; kappa stays at 562.
struct IcpReliabilityThresholds {
  double max_condition = 562.3;              // kappa = sigma_max / sigma_min of AtA
  double max_residual_per_weight = 4.22e-5;  // r / sum(w), m^2
  /// The paired share of the current frame's valid pixels, each counted by its inverse depth
  /// noise variance (DepthNoiseModel::information): far pixels, whose normals scatter past the
  /// normal-angle gate wherever the frame is aligned, count little.
  double min_inlier_fraction = 0.40;
  /// The paired share of the current frame's valid pixels, each pixel counting one: a pose that
  /// slid along the model leaves its far pixels unpaired, which the information-weighted
  /// fraction barely sees. Below the 37-40 % that an aligned frame facing a far room pairs.
  double min_pixel_fraction = 0.35;
  std::uint64_t min_inliers = 100;  // a floor for tiny images

  /// These thresholds with the residual test widened to a frame's depth noise: at least twice
  /// its mean sigma(z)^2 `noise_variance` (m^2, DepthNoiseModel::mean_variance), the most that
  /// sigma_cur^2 + sigma_model^2 reaches (a far scene is noisier, not misaligned).
  IcpReliabilityThresholds widened_to_noise(double noise_variance) const;
};

/// The photometric term of ICP (add_photometric): at ICP's finest level, on tracked frames (the
/// Reconstructor) where the frame and the model both have colour, each current pixel's
/// intensity (Rec. 601 luma in [0, 1]) against the model's raycast colour where the pixel
/// projects, linearized through the colour's gradient.
struct IcpPhotometricConfig {
  /// Its weight against the depth term, each term first weighed by the inverse of its own mean
  /// squared residual (1: equal information); 0: depth alone. Default 1 (bench/README.md: TUM
  /// fr1_xyz 19.0-19.1 mm at frame steps 1-4, none lost, against 20.1-21.7 mm without).
  double weight = 1;
  /// The Huber threshold in units of the last photometric RMS residual (default 1.345: 95 %
  /// efficiency on Gaussian noise), and before any residual was measured (intensity, 0.1).
  double huber_sigmas = 1.345;
  double initial_huber = 0.1;
  /// The term samples every `pixel_step`-th pixel of ICP's level in x and y, each sample weighed
  /// as the pixel_step^2 pixels it stands for (the model's colours are correlated over
  /// neighbouring pixels). Default 2 (bench/README.md: a quarter of the cost, the same accuracy).
  int pixel_step = 2;
  /// The camera's least intensity noise (1 sigma, intensity in [0, 1]): the colour's mean
  /// squared residual counts as at least its square, so a colour that the model reproduces almost
  /// exactly (a synthetic one, a flat shade) is not taken as near-exact evidence. Default 0.02.
  double min_sigma = 0.02;
};

/// The directions point-to-plane ICP fixes on a plane: the distance to it and its two tilts.
inline constexpr int kPlaneDirections = 3;

struct IcpConfig {
  /// Gauss-Newton iterations allowed per pyramid level, coarsest last (level 0 = full size).
  std::vector<int> iterations_per_level = {10, 5, 4};
  int max_total_iterations = 30;  // cap over all levels (1 = the paper's IMU setting)
  /// Past that cap, level 0 goes on while its last step moved the pose by more than the frame's
  /// noise allows: the step's chi^2 under ICP's own covariance, (AtA / (c s^2))^-1 (see
  /// seed_prior), above `settled_chi2`; up to `max_unsettled_iterations` steps in all (a value
  /// up to max_total_iterations leaves the cap fixed). Defaults 10 and 22.46, the 99.9 % point of
  /// chi^2 with 6 degrees of freedom (bench/README.md).
  int max_unsettled_iterations = 10;
  double settled_chi2 = 22.46;
  /// Correspondence rejection per level: point distance (m) and normal angle (deg).
  std::vector<float> max_distance = {0.10f, 0.15f, 0.20f};
  std::vector<float> max_normal_angle_deg = {20.f, 25.f, 30.f};
  NormalGate normal_gate;  // widens max_normal_angle_deg where the depth is noisy
  /// Convergence: stop a level when the update is below both (rad, m).
  double converged_rotation = 1e-5;
  double converged_translation = 1e-5;
  IcpReliabilityThresholds reliability;
  /// The depth sensor's noise: the inlier fraction's weights, and (Reconstructor) the residual
  /// test's allowance on far scenes.
  DepthNoiseModel depth_noise;
  /// Degeneracy-aware solving: directions of the 6-D update whose singular value is below
  /// sigma_max / reliability.max_condition (the geometry barely constrains them: a flat wall
  /// leaves its two in-plane translations and the rotation about its normal) are not updated
  /// and keep the initial pose. Use it when the initial pose comes from the IMU: the result then
  /// takes ICP's motion where the depth constrains it and the IMU's elsewhere (see
  /// IcpResult::partial). Off: the plain SVD solution in all six directions.
  bool keep_seed_in_degenerate_directions = false;
  /// With keep_seed_in_degenerate_directions: the fewest directions the depth must constrain
  /// for a partial result (a plane constrains three).
  int min_constrained_directions = kPlaneDirections;
  /// With keep_seed_in_degenerate_directions: a partial result's inlier and pixel fractions need
  /// reach only this, where it is below reliability's (a lost frame's view past the model's
  /// surface); 0 (default): reliability's.
  double partial_min_fraction = 0;
  /// The initial pose's uncertainty (1 sigma per axis of the update x: rad for alpha, beta,
  /// gamma and m for tx, ty, tz), e.g. of an inertial prediction; 0: unknown, no gate. With
  /// keep_seed_in_degenerate_directions, ICP's motion away from the initial pose along each
  /// singular direction of the last step whose kappa_i = sigma_max / sigma_i exceeds
  /// `seed_gate_condition` is compared with the combined uncertainty of the initial pose and of
  /// ICP there; beyond `seed_gate_sigmas`, the direction keeps the initial pose (the result is
  /// partial): the depth constrains it weakly, and the few pixels that do can pull the pose
  /// along a wall, a pillar or a model's rounded edge frame after frame. Measured on the twelve
  /// evaluation wall scans (bench/README.md, "ICP checked against the inertial prediction"):
  /// over 3642 checks of frames whose step was within 1.5 mm of the truth, the disagreement's RMS
  /// is 0.65 sigma, its 99.9th percentile 2.3 and its largest 3.0; 4 sigma flags none of them.
  double seed_sigma_rotation = 0;
  double seed_sigma_translation = 0;
  double seed_gate_condition = 30;
  double seed_gate_sigmas = 4;
  /// The Reconstructor's threshold for the frames that follow a gated one, until a frame's
  /// weak directions agree again: a slide, once caught, is held off while it goes on (the
  /// prediction's velocity then no longer learns from it, so each frame's disagreement is one
  /// frame's slide, smaller than the catch).
  double seed_gate_hold_sigmas = 2;
  /// Run the seed gate above (with keep_seed_in_degenerate_directions and seed sigmas).
  bool seed_gate = true;
  /// The initial pose as a measurement in Gauss-Newton (an inertial prediction with the seed
  /// sigmas above; a zero sigma adds nothing): each step solves
  /// (AtA / (c s^2) + L) x = Atb / (c s^2) + L d, where d moves back to the initial pose,
  /// L = diag(1 / seed_sigma^2), s^2 = max(r / sum(w) of the depth-only step, depth_noise.a^2)
  /// the noise the frame shows (m^2) and c the pixels one depth error spreads over. Default off.
  bool seed_prior = false;
  /// c at level 0: pixels sharing one depth error (the bilateral window, (2 radius + 1)^2);
  /// divided by 4 per coarser level, at least 1. Default 49.
  double correlated_pixels = 49;
  /// With both seed sigmas (seed_prior or not): a converged, well-conditioned frame whose only
  /// faults are the pairing and residual tests (fractions at least half their thresholds,
  /// r / sum(w) at most twice its) is reliable when its move from the initial pose has chi^2
  /// (6 dof, combined covariance of seed and ICP) below this. Default 22.46 (99.9 %); 0: off.
  double seed_agreement_chi2 = 22.46;
  /// The photometric term (the Reconstructor, on frames with colour).
  IcpPhotometricConfig photometric;

  Status validate(int levels) const;
};

/// ICP quality, from the last Gauss-Newton step at the finest level run.
struct IcpQuality {
  double residual = 0;                 // r = sum w (a.x - b)^2 at the solution x, m^2
  double residual_per_inlier = 0;      // r / n
  double residual_per_weight = 0;      // r / sum(w)
  std::uint64_t inliers = 0;           // n
  double inlier_fraction = 0;          // inlier_information / valid_information (NormalEquations)
  double pixel_fraction = 0;           // inliers / valid_pixels
  double covered_fraction = 0;         // NormalEquations::covered_fraction
  double covered_inlier_fraction = 0;  // NormalEquations::covered_inlier_fraction
  double weight_sum = 0;               // sum(w)
  double condition = 0;                // kappa = sigma_max / sigma_min of AtA (inf when singular)
  /// kappa of AtA's translation block (inf when singular or not evaluated): how well the depth
  /// fixes the position at a known orientation. A wall leaves two of its directions free.
  double translation_condition = std::numeric_limits<double>::infinity();
  int iterations = 0;         // Gauss-Newton steps run, all levels
  int coarse_iterations = 0;  // of those, the steps run below full resolution (levels 1..)
  bool converged = false;     // the finest level's update fell below the thresholds
  /// Directions of the last step updated by ICP: 6 unless degeneracy-aware solving left some at
  /// the initial pose.
  int constrained_directions = 6;
  /// The largest disagreement with the initial pose, in sigmas, along the directions the seed
  /// gate checks (IcpConfig::seed_sigma_rotation); 0 when no gate ran.
  double seed_disagreement = 0;
  /// Directions the seed gate moved back to the initial pose.
  int seed_gated_directions = 0;
  /// chi^2 (6 dof) of the move from the initial pose under the combined covariance of the seed
  /// and of ICP (both seed sigmas given, level 0 reached); 0 otherwise.
  double seed_chi2 = 0;
  /// The pairing or residual tests failed, and the frame was judged reliable because it
  /// converged, is well conditioned and agrees with the initial pose (seed_agreement_chi2).
  bool agreed_with_seed = false;
};

/// What an alignment may be used for: every direction (reliable), some (partial), none.
enum class IcpVerdict { kUnreliable, kReliable, kPartial };

struct IcpResult {
  Eigen::Isometry3d T_ref_cur = Eigen::Isometry3d::Identity();  // always finite
  IcpQuality quality;
  /// kPartial (degeneracy-aware solving only): the alignment passed every test but the
  /// condition number, the depth constrained at least min_constrained_directions directions and
  /// the others kept the initial pose.
  IcpVerdict verdict = IcpVerdict::kUnreliable;
  bool reliable() const { return verdict == IcpVerdict::kReliable; }
  bool partial() const { return verdict == IcpVerdict::kPartial; }
  /// The directions a partial result fixed; 0 unless partial.
  int partial_directions() const { return partial() ? quality.constrained_directions : 0; }
  /// For a partial result, the translation directions ICP fixed (a projector in the reference
  /// camera frame, see IcpStep::fixed_translation); identity for a full solve.
  Eigen::Matrix3d fixed_translation = Eigen::Matrix3d::Identity();
  /// Why the result is unreliable ("condition 2.1e4 > 150", "no valid pixels"), empty if reliable.
  std::string reason;
};

/// Evaluates the normal equations for a pose; the GPU (or the CPU reference) behind it.
class NormalEquationSource {
 public:
  virtual ~NormalEquationSource() = default;
  virtual int levels() const = 0;
  virtual Result<NormalEquations> evaluate(int level, const Eigen::Isometry3d& T_ref_cur,
                                           float max_distance, float min_normal_cos) = 0;
};

/// One Gauss-Newton step of the linearized system: x (alpha, beta, gamma, tx, ty, tz) from the
/// SVD of AtA, the residual at x, and the condition number. `solvable` is false for an empty or
/// non-finite system.
struct IcpStep {
  Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();
  double residual = 0;
  double condition = 0;
  bool solvable = false;
  int constrained_directions = 0;  // singular directions that x moves along
  /// The translation directions x takes from the depth (a projector, reference camera frame):
  /// the orthogonal complement of the translation parts of the directions left out. Identity
  /// when all six are solved, zero when none is.
  Eigen::Matrix3d fixed_translation = Eigen::Matrix3d::Zero();
  /// AtA's SVD (AtA = U S U^T): singular values, descending, and their directions (U's columns).
  /// Zero when the system was not finite.
  Eigen::Matrix<double, 6, 1> singular_values = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 6> directions = Eigen::Matrix<double, 6, 6>::Zero();
};
/// With `max_condition` > 0, x is the truncated-SVD solution: it moves only along singular
/// directions whose singular value is at least sigma_max / max_condition (zero along the others).
IcpStep solve_icp_step(const NormalEquations& eq, double max_condition = 0);

/// The incremental transform of x: rotation exp([alpha, beta, gamma]) (exact, so it stays
/// orthonormal), translation (tx, ty, tz).
Eigen::Isometry3d icp_increment(const Eigen::Matrix<double, 6, 1>& x);

/// With the orientation known (the gyroscope's): whether an alignment fixes the position. It ran,
/// passes every test of `thresholds` but the condition number, and the condition of its
/// translation alone (IcpQuality::translation_condition) is at most `max_translation_condition`
/// (0: never).
bool fixes_position(const IcpQuality& quality, IcpReliabilityThresholds thresholds,
                    double max_translation_condition);

/// The reliable / unreliable decision on a quality; the reason when unreliable.
bool judge_icp(const IcpQuality& quality, const IcpReliabilityThresholds& thresholds,
               std::string* reason);

/// Coarse-to-fine Gauss-Newton from `T_ref_cur_init`. Never returns a non-finite pose: on
/// failure the result is unreliable and the pose is the initial one (or identity if that is
/// not finite).
Result<IcpResult> run_icp(NormalEquationSource& source, const IcpConfig& config,
                          const Eigen::Isometry3d& T_ref_cur_init);

/// GPU ICP between depth frames: preprocesses a reference and a current frame on the device and
/// aligns them. The reference is a depth image seen from the reference camera (the previous frame
/// for frame-to-frame tracking, or a rendering of the model at a predicted pose).
class IcpTracker {
 public:
  static Result<IcpTracker> create(const IcpConfig& icp, const PreprocessConfig& preprocess,
                                   const Intrinsics& intrinsics, const DeviceOptions& device = {});
  ~IcpTracker();
  IcpTracker(IcpTracker&&) noexcept;
  IcpTracker& operator=(IcpTracker&&) noexcept;

  /// Frame-to-frame: the reference is a depth image (preprocessed like the current frame).
  Status set_reference(const DepthImage& depth);
  /// Frame-to-model: the reference is given as full-resolution vertex and normal maps in the
  /// reference camera's frame, e.g. Reconstructor::raycast at the predicted pose.
  Status set_reference_maps(const Vec4Image& vertices, const Vec4Image& normals);
  /// Aligns `depth` to the reference, starting at T_ref_cur_init. `timings` collects the GPU time
  /// of every association and reduction dispatch.
  Result<IcpResult> track(const DepthImage& depth, const Eigen::Isometry3d& T_ref_cur_init,
                          std::vector<KernelTiming>* timings = nullptr);

  const DeviceInfo& device() const;
  std::uint32_t validation_error_count() const;

 private:
  struct Impl;
  explicit IcpTracker(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imufusion

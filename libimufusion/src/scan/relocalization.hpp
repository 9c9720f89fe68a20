#pragma once
// RelocalizationDriver: when a lost frame searches the model for where it fits
// (ReconstructorConfig::relocalization), the search itself (core/relocalizer.hpp) over a distance
// field of the model, and full ICP from its best candidates.

#include <algorithm>
#include <optional>
#include <vector>

#include "core/relocalizer.hpp"
#include "core/state_archive.hpp"
#include "scan/model_aligner.hpp"

namespace imufusion {

class RelocalizationDriver {
 public:
  /// A tracked frame, as relocalization sees it.
  struct Frame {
    double timestamp = 0;            // s
    bool lost = false;               // the scan was lost before this frame
    bool rotation_from_imu = false;  // the seed's rotation came from the gyroscope
    bool icp_reliable = false;       // ICP from the seed placed the frame in every direction
    int partial_directions = 0;      // the directions a partial ICP from the seed fixed, else 0
    // Where the frame is without a search: its orientation is kept, its translation searched.
    Eigen::Isometry3d T_world_estimate = Eigen::Isometry3d::Identity();
    double constrained_time = 0;                        // s: the last fully constrained frame's
    Eigen::Vector3d lost_at = Eigen::Vector3d::Zero();  // world, m: that frame's position
  };
  struct Outcome {
    /// The dead-reckoned seed may lie beyond ICP's reach: ICP from it ends the loss only when
    /// the search confirms it.
    bool long_loss = false;
    std::optional<ModelAligner::Placement> found;  // the alignment a search accepted
  };

  RelocalizationDriver() = default;
  explicit RelocalizationDriver(const ReconstructorConfig& config);

  /// Counts the lost frames and, where this one searches (every relocalization.interval lost
  /// frames, the next lost frame after a search whose best fit waits for confirmation or failed
  /// only the condition number by at most relocalization.near_fit_condition_factor, with the
  /// gyroscope every lost frame whose partial ICP fixed more directions than a plane does, and
  /// whenever ICP from the seed would end a long loss), runs the search with
  /// `model`'s current frame, `depth`. The search's raycasts and ICP add their kernels to
  /// `timings`, their wall time to relocalize_ms only.
  Result<Outcome> on_frame(const Frame& frame, const DepthView& depth, ModelAligner& model,
                           FrameTimings& timings);
  /// The model changed (a frame was fused): the distance field is built again at the next search.
  void model_changed() { field_current_ = coarse_current_ = false; }
  /// A frame was fused at `R_world_camera`: its orientation joins those that the search without
  /// the gyroscope sweeps, unless one within half a turn step is there already.
  void note_view(const Eigen::Matrix3d& R_world_camera);
  void reset();
  void describe(StateArchive& archive);  // the changing state, for a saved scan

 private:
  // Where a candidate's ICP placed the frame (world, m) and its residual per weight (m^2).
  struct Fit {
    Eigen::Vector3d at;
    double residual_per_weight = 0;
    double inlier_fraction = 0;  // IcpQuality::inlier_fraction
    // With the gyroscope: it would place the frame, its kappa within the limit or its position
    // fixed (fixes_position).
    bool places = false;
  };
  // A place the search proposes: the frame's orientation there and its translation.
  struct Oriented {
    Eigen::Matrix3d R_world_camera;
    TranslationCandidate at;
  };
  double drift_radius(double lost_seconds) const;
  // m: how far a hand-held camera (inertial.max_speed) goes in `seconds`.
  double reach(double seconds) const { return max_speed_ * std::max(0.0, seconds); }
  bool long_loss(const Frame& frame) const;
  bool should_search(const Frame& frame, bool long_loss);
  void forget_ambiguity();
  Status build_field(ModelAligner& model, const Eigen::Vector3d& anchor, bool coarse);
  std::vector<Oriented> turned_candidates(const std::vector<Eigen::Vector3d>& points,
                                          const Eigen::Matrix3d& R_estimate,
                                          const Eigen::Vector3d& center, double radius) const;
  Result<std::optional<ModelAligner::Placement>> search(const Frame& frame, const DepthView& depth,
                                                        ModelAligner& model, FrameTimings& timings);

  RelocalizationConfig config_;
  double icp_reach_ = 0;  // m: ICP's largest correspondence distance, at its coarsest level
  int coarse_level_ = 0;  // the pyramid's coarsest level, where the frame's points are taken
  double max_depth_ = 0;  // m: the farthest depth preprocessing keeps
  double max_speed_ = 0;  // m/s: the fastest a hand-held camera moves (inertial.max_speed)
  // The model's distance field, built at the first search after the model last changed.
  SurfaceDistanceField field_;
  bool field_current_ = false;
  // Without the gyroscope: the same at twice the cell, for the sweep over orientations.
  SurfaceDistanceField coarse_field_;
  bool coarse_current_ = false;
  // The fused frames' orientations (camera to world), at least half a
  // relocalization.turn_step_deg apart.
  std::vector<Eigen::Quaterniond> views_;
  int lost_frames_since_attempt_ = 0;
  // World, m: where the last search of this loss put the frame relative to its estimate, when
  // its best fit waits for confirmation (not the only one; without the gyroscope, any), and
  // its other reliable fits.
  std::optional<Eigen::Vector3d> unconfirmed_correction_;
  double unconfirmed_time_ = 0;  // s: the timestamp of that search's frame
  std::vector<Eigen::Vector3d> ambiguous_alternatives_;
  bool confirm_next_ = false;  // the next lost frame searches to confirm it
  bool near_fit_ = false;      // the last search's best fit failed only the condition, narrowly
};

}  // namespace imufusion

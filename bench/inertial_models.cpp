// inertial_models: measures InertialNavigator's frame-to-frame motion prediction with each
// translation model, its online gyro bias and hand-eye estimates, and dead reckoning through the
// wall scene's featureless stretch; all on the CPU from synthetic motion and IMU (no rendering).
//
// Tracked poses are the true poses with small tracking noise (per frame, independent: rotation
// 0.05 deg, position 1 mm, about what reliable ICP achieves on the synthetic room). Prediction
// errors compare predict(t_{k-1}, t_k) with the true relative motion, over every frame after the
// first 2 s (when bias and velocity have settled). With ../shared/datasets/tum_fr1_xyz present,
// the same is measured on its ground truth and synthesized IMU.
//
//   inertial_models [--seeds N] [--seconds S] [--tum DIR]

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "imufusion/inertial.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"

using namespace imufusion;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kFps = 30.0;
constexpr double kSettle = 2.0;  // s excluded from the prediction statistics

const TranslationModel kModels[] = {TranslationModel::kNone, TranslationModel::kConstantVelocity,
                                    TranslationModel::kAccelerometer};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double pos = p * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

double angle_deg(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  return Eigen::AngleAxisd(A.transpose() * B).angle() / kDeg;
}

struct Errors {
  std::vector<double> rot_deg, trans_mm;
  void add(const Eigen::Isometry3d& predicted, const Eigen::Isometry3d& truth) {
    rot_deg.push_back(angle_deg(predicted.linear(), truth.linear()));
    trans_mm.push_back(1e3 * (predicted.translation() - truth.translation()).norm());
  }
  void append(const Errors& o) {
    rot_deg.insert(rot_deg.end(), o.rot_deg.begin(), o.rot_deg.end());
    trans_mm.insert(trans_mm.end(), o.trans_mm.begin(), o.trans_mm.end());
  }
};

/// A pose sequence with the tracking noise applied.
struct TrackingNoise {
  std::mt19937_64 rng;
  std::normal_distribution<double> n{0.0, 1.0};
  double rot_sigma = 0.05 * kDeg, pos_sigma = 0.001;
  Eigen::Isometry3d apply(const Eigen::Isometry3d& T) {
    Eigen::Isometry3d out = T;
    const Eigen::Vector3d w(n(rng), n(rng), n(rng));
    out.linear() =
        T.linear() * Eigen::AngleAxisd(rot_sigma * w.norm(), w.normalized()).toRotationMatrix();
    out.translation() += pos_sigma * Eigen::Vector3d(n(rng), n(rng), n(rng));
    return out;
  }
};

InertialConfig base_config(const Eigen::Isometry3d& T_camera_imu, TranslationModel model) {
  InertialConfig c;
  c.T_camera_imu = T_camera_imu;
  c.translation = model;
  return c;
}

/// One run over a synthetic motion. `dead_reckon` frames are observed as unreliable with the
/// dead-reckoned pose (pose_a * prediction) instead of the tracked one.
// ms into the dead-reckoned stretch at which its drift is reported.
constexpr int kDriftTimesMs[] = {300, 500, 800, 1000, 2000};

struct RunResult {
  Errors errors;                         // frames after kSettle
  std::map<int, double> bias_error;      // second -> |b - b_true| (rad/s)
  std::map<int, double> hand_eye_error;  // second -> deg, NaN before the estimate is used
  double switch_time = NAN;              // s after start when the hand-eye estimate was used
  double drift_pos_mm = NAN, drift_rot_deg = NAN;  // at the end of the dead-reckoned stretch
  std::map<int, double> drift_pos_at_mm;           // ms into the stretch -> position error (mm)
  double check_deg = NAN;   // a given mounting's angle from the hand-eye check, at the end
  double flagged_at = NAN;  // s after start when the given mounting was first flagged
};

RunResult run(const synth::CameraMotion& motion, std::uint64_t seed, double seconds,
              const InertialConfig& config, const std::vector<ImuSample>& samples,
              const synth::ImuBias& bias, const Eigen::Matrix3d& R_ci_true,
              const std::optional<synth::TimeSpan>& dead_reckon) {
  RunResult out;
  InertialNavigator nav = InertialNavigator::create(config).value();
  TrackingNoise noise{std::mt19937_64(seed * 7919 + 13)};
  const double t0 = motion.start_time();
  std::size_t next = 0;
  Eigen::Isometry3d pose_a = noise.apply(motion.pose_at(t0));
  const int frames = static_cast<int>(seconds * kFps);
  for (int k = 1; k <= frames; ++k) {
    const double ta = t0 + (k - 1) / kFps, tb = t0 + k / kFps;
    std::size_t end = next;
    while (end < samples.size() && samples[end].timestamp <= tb + 0.006) ++end;
    if (!nav.add_samples(std::span(samples).subspan(next, end - next)).ok()) std::abort();
    next = end;
    const MotionPrediction p = nav.predict(ta, tb);
    const Eigen::Isometry3d truth = motion.pose_at(ta).inverse() * motion.pose_at(tb);
    if (tb - t0 > kSettle && !dead_reckon) out.errors.add(p.T_a_b, truth);
    const bool dark = dead_reckon && tb > dead_reckon->begin && tb <= dead_reckon->end;
    const Eigen::Isometry3d pose_b = dark ? pose_a * p.T_a_b : noise.apply(motion.pose_at(tb));
    nav.observe(ta, tb, pose_a, pose_b, !dark);
    if (dark) {
      const int ms = static_cast<int>(std::lround(1e3 * (tb - dead_reckon->begin)));
      for (const int at : kDriftTimesMs) {
        if (std::abs(ms - at) * kFps < 500)  // the frame within half a period of `at`
          out.drift_pos_at_mm[at] =
              1e3 * (pose_b.translation() - motion.pose_at(tb).translation()).norm();
      }
    }
    if (dark && tb + 1.0 / kFps > dead_reckon->end) {
      // Drift over the stretch: the dead-reckoned pose against the truth, relative to where
      // dead reckoning started (the tracked pose at the stretch's start had its own noise).
      const Eigen::Isometry3d T_true = motion.pose_at(tb);
      out.drift_pos_mm = 1e3 * (pose_b.translation() - T_true.translation()).norm();
      out.drift_rot_deg = angle_deg(pose_b.linear(), T_true.linear());
    }
    pose_a = pose_b;
    const double elapsed = tb - t0;
    const InertialStatus st = nav.status();
    if (st.R_camera_imu_estimated && std::isnan(out.switch_time)) out.switch_time = elapsed;
    if (st.R_camera_imu_disagrees && std::isnan(out.flagged_at)) out.flagged_at = elapsed;
    if (st.R_camera_imu_disagreement_deg > 0) out.check_deg = st.R_camera_imu_disagreement_deg;
    if (std::abs(elapsed - std::round(elapsed)) < 0.5 / kFps) {
      const int second = static_cast<int>(std::round(elapsed));
      out.bias_error[second] = (st.gyro_bias - bias.gyro).norm();
      out.hand_eye_error[second] = st.R_camera_imu_estimated || config.T_camera_imu_known
                                       ? angle_deg(st.R_camera_imu.toRotationMatrix(), R_ci_true)
                                       : NAN;
    }
  }
  return out;
}

void print_prediction_table(const std::map<std::string, std::map<TranslationModel, Errors>>& e,
                            const std::map<std::string, Errors>& no_imu) {
  std::printf(
      "| scene | model | rot median deg | rot p95 deg | trans median mm | trans p95 mm |\n");
  std::printf("| --- | --- | --- | --- | --- | --- |\n");
  for (const auto& [scene, by_model] : e) {
    const Errors& base = no_imu.at(scene);
    std::printf("| %s | no IMU (identity) | %.3f | %.3f | %.2f | %.2f |\n", scene.c_str(),
                percentile(base.rot_deg, 0.5), percentile(base.rot_deg, 0.95),
                percentile(base.trans_mm, 0.5), percentile(base.trans_mm, 0.95));
    for (const auto& [model, err] : by_model) {
      std::printf("| %s | %s | %.3f | %.3f | %.2f | %.2f |\n", scene.c_str(), to_string(model),
                  percentile(err.rot_deg, 0.5), percentile(err.rot_deg, 0.95),
                  percentile(err.trans_mm, 0.5), percentile(err.trans_mm, 0.95));
    }
  }
}

void print_over_time(const char* title, const char* unit, double scale,
                     const std::vector<std::map<int, double>>& runs) {
  std::printf("\n%s (%s; median / p95 over runs; '-' while not yet estimated)\n\n", title, unit);
  std::printf("| after s | median | p95 | runs estimated |\n| --- | --- | --- | --- |\n");
  for (const int s : {1, 2, 3, 5, 10, 20, 30}) {
    std::vector<double> v;
    int present = 0;
    for (const auto& r : runs) {
      const auto it = r.find(s);
      if (it == r.end()) continue;
      ++present;
      if (!std::isnan(it->second)) v.push_back(it->second * scale);
    }
    if (present == 0) continue;
    if (v.empty()) {
      std::printf("| %d | - | - | 0 / %d |\n", s, present);
    } else {
      std::printf("| %d | %.4f | %.4f | %zu / %d |\n", s, percentile(v, 0.5), percentile(v, 0.95),
                  v.size(), present);
    }
  }
}

/// Linear / slerp interpolation of a trajectory at t; nullopt outside it or across a gap > 0.1 s.
std::optional<Eigen::Isometry3d> pose_at(const Trajectory& traj, double t) {
  const auto it = std::lower_bound(traj.begin(), traj.end(), t,
                                   [](const StampedPose& p, double v) { return p.timestamp < v; });
  if (it == traj.begin() || it == traj.end()) return std::nullopt;
  const StampedPose& a = *std::prev(it);
  const StampedPose& b = *it;
  if (b.timestamp - a.timestamp > 0.1) return std::nullopt;
  const double w = (t - a.timestamp) / (b.timestamp - a.timestamp);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(a.T_world_camera.linear())
                   .slerp(w, Eigen::Quaterniond(b.T_world_camera.linear()))
                   .toRotationMatrix();
  T.translation() = (1 - w) * a.T_world_camera.translation() + w * b.T_world_camera.translation();
  return T;
}

void run_tum(const std::filesystem::path& dir) {
  SequenceOptions opts;
  opts.load_color = false;
  Result<SequenceReader> reader = SequenceReader::open(dir, opts);
  if (!reader.ok()) {
    std::printf("\n%s: %s (skipped)\n", dir.c_str(), reader.error().describe().c_str());
    return;
  }
  const SequenceInfo& info = reader->info();
  Eigen::Vector3d true_bias = Eigen::Vector3d::Zero();
  if (const auto it = info.info.find("gyro_bias"); it != info.info.end()) {
    std::istringstream(it->second) >> true_bias.x() >> true_bias.y() >> true_bias.z();
  }
  const std::vector<double> stamps = reader->timestamps();
  std::printf("\nTUM %s: %zu depth frames, %zu IMU samples, ground truth at depth stamps\n\n",
              dir.filename().c_str(), stamps.size(), info.imu.size());
  std::printf(
      "| model / run | frames | rot median deg | rot p95 deg | trans median mm | trans p95 mm "
      "| final bias error deg/s | R_camera_imu error deg |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- | --- |\n");
  struct Variant {
    std::string name;
    TranslationModel model;
    bool known;
  };
  std::vector<Variant> variants;
  for (const TranslationModel m : kModels) variants.push_back({to_string(m), m, true});
  variants.push_back(
      {"constant-velocity, mounting estimated", TranslationModel::kConstantVelocity, false});
  Errors no_imu;
  for (const Variant& v : variants) {
    InertialConfig config = base_config(info.T_camera_imu, v.model);
    config.T_camera_imu_known = v.known;
    if (!v.known) config.T_camera_imu = Eigen::Isometry3d::Identity();
    InertialNavigator nav = InertialNavigator::create(config).value();
    Errors err;
    std::size_t next = 0;  // samples are fed as a driver delivers them: up to just past a frame
    std::optional<Eigen::Isometry3d> prev = pose_at(info.ground_truth, stamps[0]);
    for (std::size_t k = 1; k < stamps.size(); ++k) {
      const std::optional<Eigen::Isometry3d> cur = pose_at(info.ground_truth, stamps[k]);
      std::size_t end = next;
      while (end < info.imu.size() && info.imu[end].timestamp <= stamps[k] + 0.006) ++end;
      if (!nav.add_samples(std::span(info.imu).subspan(next, end - next)).ok()) return;
      next = end;
      if (prev && cur) {
        const MotionPrediction p = nav.predict(stamps[k - 1], stamps[k]);
        if (stamps[k] - stamps[0] > kSettle) {
          err.add(p.T_a_b, prev->inverse() * *cur);
          if (&v == &variants.front())
            no_imu.add(Eigen::Isometry3d::Identity(), prev->inverse() * *cur);
        }
        nav.observe(stamps[k - 1], stamps[k], *prev, *cur, true);
      } else {
        nav.reset();
      }
      prev = cur;
    }
    const InertialStatus st = nav.status();
    std::printf("| %s | %zu | %.3f | %.3f | %.2f | %.2f | %.4f | %.3f |\n", v.name.c_str(),
                err.rot_deg.size(), percentile(err.rot_deg, 0.5), percentile(err.rot_deg, 0.95),
                percentile(err.trans_mm, 0.5), percentile(err.trans_mm, 0.95),
                (st.gyro_bias - true_bias).norm() / kDeg,
                angle_deg(st.R_camera_imu.toRotationMatrix(), info.T_camera_imu.linear()));
  }
  std::printf("| no IMU (identity) | %zu | %.3f | %.3f | %.2f | %.2f | | |\n",
              no_imu.rot_deg.size(), percentile(no_imu.rot_deg, 0.5),
              percentile(no_imu.rot_deg, 0.95), percentile(no_imu.trans_mm, 0.5),
              percentile(no_imu.trans_mm, 0.95));
}

// Everything the runs over scenes and seeds collect.
struct Collected {
  std::map<std::string, std::map<TranslationModel, Errors>> errors;
  std::map<std::string, Errors> no_imu;
  std::map<TranslationModel, std::vector<double>> drift_pos, drift_rot;
  std::map<TranslationModel, std::map<int, std::vector<double>>> drift_pos_at;
  std::vector<std::map<int, double>> bias_runs, hand_eye_runs, hand_eye_bias_runs;
  std::vector<double> switch_times;
  // The check of a given mounting: the true one (angle at the end, s when wrongly flagged) and
  // the identity given for the phone's 180 deg mounting (s when flagged).
  std::map<std::string, std::vector<double>> true_check_deg, true_flagged_at, identity_flagged_at;
};

// One scene and seed: every translation model (and the wall's dead reckoning), the frames
// without an IMU, and the hand-eye estimate from the identity.
void collect_seed(synth::SceneKind kind, std::uint64_t seed, double seconds,
                  const synth::ImuConfig& imu, Collected& c) {
  const Eigen::Isometry3d T_ci = imu.T_camera_imu;
  const synth::CameraMotion motion(kind, seed, 100.0);
  const synth::ImuBias bias = synth::draw_imu_bias(seed);
  const std::vector<ImuSample> samples =
      synth::generate_imu(motion, imu, bias, 99.9, 100.0 + seconds + 0.2, seed);
  for (const TranslationModel model : kModels) {
    const RunResult r = run(motion, seed, seconds, base_config(T_ci, model), samples, bias,
                            T_ci.linear(), std::nullopt);
    c.errors[synth::to_string(kind)][model].append(r.errors);
    if (model == TranslationModel::kNone) {
      c.bias_runs.push_back(r.bias_error);
      c.true_check_deg[synth::to_string(kind)].push_back(r.check_deg);
      c.true_flagged_at[synth::to_string(kind)].push_back(r.flagged_at);
    }
    if (kind == synth::SceneKind::kWall) {
      const RunResult d = run(motion, seed, seconds, base_config(T_ci, model), samples, bias,
                              T_ci.linear(), motion.wall_stretch());
      c.drift_pos[model].push_back(d.drift_pos_mm);
      for (const auto& [at, mm] : d.drift_pos_at_mm) c.drift_pos_at[model][at].push_back(mm);
      c.drift_rot[model].push_back(d.drift_rot_deg);
    }
  }
  for (int k = 1; k <= static_cast<int>(seconds * kFps); ++k) {
    const double ta = 100.0 + (k - 1) / kFps, tb = 100.0 + k / kFps;
    if (tb - 100.0 > kSettle) {
      c.no_imu[synth::to_string(kind)].add(Eigen::Isometry3d::Identity(),
                                           motion.pose_at(ta).inverse() * motion.pose_at(tb));
    }
  }
  InertialConfig unknown =
      base_config(Eigen::Isometry3d::Identity(), TranslationModel::kConstantVelocity);
  unknown.T_camera_imu_known = false;
  const RunResult h =
      run(motion, seed, seconds, unknown, samples, bias, T_ci.linear(), std::nullopt);
  c.hand_eye_runs.push_back(h.hand_eye_error);
  c.hand_eye_bias_runs.push_back(h.bias_error);
  c.switch_times.push_back(std::isnan(h.switch_time) ? 1e9 : h.switch_time);
  const InertialConfig wrong =
      base_config(Eigen::Isometry3d::Identity(), TranslationModel::kConstantVelocity);
  c.identity_flagged_at[synth::to_string(kind)].push_back(
      run(motion, seed, seconds, wrong, samples, bias, T_ci.linear(), std::nullopt).flagged_at);
}

void print_mounting_check(const Collected& c) {
  const auto finite = [](const std::vector<double>& values) {
    std::vector<double> out;
    for (const double v : values)
      if (!std::isnan(v)) out.push_back(v);
    return out;
  };
  std::printf(
      "\nA given mounting checked by the hand-eye estimate (mounting_check_deg %.1f), per scene: "
      "the true mounting (runs flagged; its angle from the check, median / max deg, runs "
      "checked) and the identity, 180 deg off (runs flagged; s until flagged, median / max)\n\n"
      "| scene | true: flagged | true: angle deg | true: checked | identity: flagged | "
      "identity: s |\n| --- | --- | --- | --- | --- | --- |\n",
      InertialConfig{}.mounting_check_deg);
  for (const auto& [scene, identity] : c.identity_flagged_at) {
    const std::vector<double> checked = finite(c.true_check_deg.at(scene));
    const std::vector<double> wrong = finite(identity);
    std::printf("| %s | %zu of %zu | %.2f / %.2f | %zu | %zu of %zu | %.1f / %.1f |\n",
                scene.c_str(), finite(c.true_flagged_at.at(scene)).size(),
                c.true_flagged_at.at(scene).size(), percentile(checked, 0.5),
                percentile(checked, 1.0), checked.size(), wrong.size(), identity.size(),
                percentile(wrong, 0.5), percentile(wrong, 1.0));
  }
}

void print_dead_reckoning(const Collected& c) {
  std::printf(
      "\nDead reckoning through the wall stretch (2 s unreliable, pose_b = pose_a * "
      "prediction): error at its end, median / p95 over seeds\n\n");
  std::printf("| model | position mm | rotation deg |\n| --- | --- | --- |\n");
  for (const TranslationModel m : kModels) {
    std::printf("| %s | %.0f / %.0f | %.3f / %.3f |\n", to_string(m),
                percentile(c.drift_pos.at(m), 0.5), percentile(c.drift_pos.at(m), 0.95),
                percentile(c.drift_rot.at(m), 0.5), percentile(c.drift_rot.at(m), 0.95));
  }
  std::printf("\nPosition drift into the stretch, mm, median / p95 over seeds\n\n| model |");
  for (const int at : kDriftTimesMs) std::printf(" %d ms |", at);
  std::printf("\n| --- |");
  for (std::size_t i = 0; i < std::size(kDriftTimesMs); ++i) std::printf(" --- |");
  std::printf("\n");
  for (const TranslationModel m : kModels) {
    std::printf("| %s |", to_string(m));
    for (const int at : kDriftTimesMs)
      std::printf(" %.1f / %.1f |", percentile(c.drift_pos_at.at(m).at(at), 0.5),
                  percentile(c.drift_pos_at.at(m).at(at), 0.95));
    std::printf("\n");
  }
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 12;
  std::uint64_t first_seed = 301;  // none used by the tests
  double seconds = 30.0;
  std::filesystem::path tum = "../shared/datasets/tum_fr1_xyz";  // from the repository root
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) {
      seeds = std::atoi(argv[++i]);
    } else if (a == "--first-seed" && i + 1 < argc) {
      first_seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (a == "--seconds" && i + 1 < argc) {
      seconds = std::atof(argv[++i]);
    } else if (a == "--tum" && i + 1 < argc) {
      tum = argv[++i];
    } else {
      std::fprintf(
          stderr,
          "usage: inertial_models [--seeds N] [--first-seed N] [--seconds S] [--tum DIR]\n");
      return 2;
    }
  }
  if (seeds < 1 || !(seconds >= 12.0)) {
    std::fprintf(stderr, "inertial_models: need --seeds >= 1 and --seconds >= 12 (wall episode)\n");
    return 2;
  }
  const synth::ImuConfig imu;  // noise and bias on, default mounting
  Collected c;
  for (const synth::SceneKind kind :
       {synth::SceneKind::kRoom, synth::SceneKind::kWall, synth::SceneKind::kFast}) {
    for (int s = 0; s < seeds; ++s)
      collect_seed(kind, first_seed + static_cast<std::uint64_t>(s), seconds, imu, c);
  }

  std::printf(
      "Prediction error per frame (30 Hz, %d seeds per scene, %.0f s each, frames after "
      "%.0f s; tracked poses = truth + 0.05 deg / 1 mm noise)\n\n",
      seeds, seconds, kSettle);
  print_prediction_table(c.errors, c.no_imu);
  print_dead_reckoning(c);
  print_over_time("Gyro bias error, mounting known", "deg/s", 1.0 / kDeg, c.bias_runs);
  print_over_time("Mounting rotation error, hand-eye from identity", "deg", 1.0, c.hand_eye_runs);
  print_over_time("Gyro bias error, mounting estimated", "deg/s", 1.0 / kDeg, c.hand_eye_bias_runs);
  std::printf(
      "\nHand-eye estimate in use after: median %.1f s, p95 %.1f s, never in %d of %zu runs\n",
      percentile(c.switch_times, 0.5), percentile(c.switch_times, 0.95),
      static_cast<int>(std::count(c.switch_times.begin(), c.switch_times.end(), 1e9)),
      c.switch_times.size());
  print_mounting_check(c);
  if (std::filesystem::exists(tum)) {
    run_tum(tum);
  } else {
    std::printf("\n%s absent: TUM figures skipped\n", tum.c_str());
  }
  return 0;
}

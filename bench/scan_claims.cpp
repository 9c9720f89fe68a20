// The paper's claims, measured: ATE, lost frames and ICP iterations per frame with the IMU
// against without, on synthetic room, wall and fast scans (seeds the tests do not use) and on a
// recorded sequence (e.g. ../shared/datasets/tum_fr1_xyz).
//
//   scan_claims [--scenes room,wall,fast] [--seeds 101,102,103] [--size WxH] [--frames N]
//               [--sequence DIR [--sequence-frames N]] [--settings imu-1,imu-2,icp-10,icp-30]
//               [--retrack-lost-frames N] [--max-condition K] [--seed-gate SIGMAS]
//               [--partial-move-sigma M] [--retracked-frame-sigma M]
//               [--recovery-agreement-distance M] [--correct-velocity-after-loss 0|1] [--work DIR]
//
// Settings compared, per scan:
//   imu-1   gyro seed, at most 1 Gauss-Newton step per frame (the paper's IMU setting)
//   imu-2   gyro seed, at most 2 (imufusion-scan's default with an IMU)
//   icp-10  no IMU, at most 10
//   icp-30  no IMU, at most 30 (the paper's comparison)
// Printed per scan and setting: ATE RMSE (mm), lost and recovering frames, recoveries, broken
// recoveries (a recovering frame followed by a lost one) and frames to recover, lost frames
// placed backward from their recovery, recovering frames that restarted the recovery's count
// (ReconstructorConfig::recovery.agreement_distance), median ICP iterations over all frames and
// over tracking frames, mean ICP iterations, whether every frame after the wall stretch tracks,
// and the frame rate.
//
// Synthetic scans with an IMU also check the inertial estimates' reported sigmas, which the
// re-estimation of a lost stretch takes as its prior: at the last frame ICP fixed in full before
// the first loss, the gyro bias, gravity, accelerometer bias and velocity estimates against the
// truth, per axis in units of the sigma reported with them, each scan once (with its first IMU
// setting). Printed after the table: the RMS of those ratios (1 for honest sigmas).
//
// Also printed after the table, for each pair of settings run: over the scans with both, on how
// many the first's ATE is no worse than the second's, the mean difference with its 95 % interval,
// and the first's largest excess.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "imufusion/eval.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/scan_report.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"

namespace fs = std::filesystem;
using namespace imufusion;

namespace {

struct Setting {
  const char* name;
  bool imu;
  int iterations;
};
constexpr Setting kSettings[] = {
    {"imu-1", true, 1}, {"imu-2", true, 2}, {"icp-10", false, 10}, {"icp-30", false, 30}};

struct Options {
  std::vector<std::string> scenes = {"room", "wall", "fast"};
  std::vector<std::uint64_t> seeds = {101, 102, 103};
  int width = 320, height = 240;
  int frames = 420;  // 14 s: the wall episode ends at 9.5 s, so 4.5 s after it must track
  fs::path sequence;
  long sequence_frames = -1;
  fs::path work = fs::temp_directory_path() / "imufusion_scan_claims";
  std::vector<std::string> settings = {"imu-1", "imu-2", "icp-10", "icp-30"};
  int retrack_lost_frames =
      ReconstructorConfig{}.smoothing.retrack_frames;               // 0: no backward placement
  double max_condition = IcpReliabilityThresholds{}.max_condition;  // the reliability test's kappa
  double partial_move_sigma = ReconstructorConfig{}.smoothing.partial_move_sigma;
  double retracked_frame_sigma = ReconstructorConfig{}.smoothing.retracked_frame_sigma;
  double recovery_agreement_distance = ReconstructorConfig{}.recovery.agreement_distance;
  bool correct_velocity_after_loss = ReconstructorConfig{}.recovery.correct_velocity;
  double seed_gate =
      0;  // > 0: ReconstructorConfig::imu.seed_gate at this IcpConfig::seed_gate_sigmas
};

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream s(text);
  for (std::string p; std::getline(s, p, ',');)
    if (!p.empty()) parts.push_back(p);
  return parts;
}

bool wanted(const Options& opt, const Setting& setting) {
  return std::find(opt.settings.begin(), opt.settings.end(), setting.name) != opt.settings.end();
}

bool parse(int argc, char** argv, Options& opt) {
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--scenes")
      opt.scenes = split(v);
    else if (a == "--seeds") {
      opt.seeds.clear();
      for (const auto& s : split(v)) opt.seeds.push_back(std::strtoull(s.c_str(), nullptr, 10));
    } else if (a == "--size") {
      if (std::sscanf(v.c_str(), "%dx%d", &opt.width, &opt.height) != 2) return false;
    } else if (a == "--frames")
      opt.frames = std::atoi(v.c_str());
    else if (a == "--sequence")
      opt.sequence = v;
    else if (a == "--sequence-frames")
      opt.sequence_frames = std::atol(v.c_str());
    else if (a == "--work")
      opt.work = v;
    else if (a == "--retrack-lost-frames")
      opt.retrack_lost_frames = std::atoi(v.c_str());
    else if (a == "--max-condition")
      opt.max_condition = std::atof(v.c_str());
    else if (a == "--seed-gate")
      opt.seed_gate = std::atof(v.c_str());
    else if (a == "--partial-move-sigma")
      opt.partial_move_sigma = std::atof(v.c_str());
    else if (a == "--retracked-frame-sigma")
      opt.retracked_frame_sigma = std::atof(v.c_str());
    else if (a == "--recovery-agreement-distance")
      opt.recovery_agreement_distance = std::atof(v.c_str());
    else if (a == "--correct-velocity-after-loss") {
      if (v != "0" && v != "1") return false;
      opt.correct_velocity_after_loss = v == "1";
    } else if (a == "--settings")
      opt.settings = split(v);
    else
      return false;
  }
  return (argc % 2) == 1 && opt.frames > 1 && opt.width > 0 && opt.height > 0;
}

struct Loaded {
  std::string label;
  std::optional<SequenceReader> reader;
  std::vector<Frame> frames;
  std::optional<double> hard_end;      // time after which every frame should track (wall scans)
  std::optional<synth::ImuBias> bias;  // the true IMU biases (synthetic scans)
};

// Sums of squared (estimate - truth) / sigma per quantity, over the axes of every scan; each scan
// counts once, with the first IMU setting run on it.
struct SigmaCheck {
  double gyro_bias = 0, gravity = 0, accel_bias = 0, velocity = 0;
  double velocity_error2 = 0;  // m^2/s^2, summed over the axes
  int axes = 0;
  std::set<std::string> scans;
  void add(const Loaded& seq, const std::vector<FrameResult>& results) {
    if (!seq.bias || !seq.reader->has_ground_truth() || seq.reader->ground_truth().empty()) return;
    if (!scans.insert(seq.label).second) return;
    const FrameResult* last = nullptr;
    for (const FrameResult& r : results) {
      if (r.status == TrackingStatus::kLost) break;
      if (r.source == PoseSource::kIcp) last = &r;
    }
    if (last == nullptr || !last->inertial.gravity_ready) return;
    const InertialStatus& e = last->inertial;
    // The scan's world is its first camera frame.
    const Eigen::Vector3d g =
        seq.reader->ground_truth().front().T_world_camera.linear().transpose() *
        synth::gravity_world();
    const auto ratio2 = [](const Eigen::Vector3d& error, const Eigen::Vector3d& sigma) {
      return error.cwiseQuotient(sigma).squaredNorm();
    };
    gyro_bias += ratio2(e.gyro_bias - seq.bias->gyro, e.gyro_bias_sigma);
    gravity += ratio2(e.gravity_world - g, e.gravity_sigma);
    accel_bias += ratio2(e.accel_bias - seq.bias->accel, e.accel_bias_sigma);
    // The IMU point's true velocity: a central difference of the ground truth around the frame.
    const Trajectory& truth = seq.reader->ground_truth();
    std::size_t k = 1;
    while (k + 2 < truth.size() && truth[k].timestamp < last->timestamp) ++k;
    const Eigen::Isometry3d world = truth.front().T_world_camera.inverse();
    const Eigen::Vector3d lever = seq.reader->T_camera_imu().translation();
    const Eigen::Vector3d v = ((world * truth[k + 1].T_world_camera) * lever -
                               (world * truth[k - 1].T_world_camera) * lever) /
                              (truth[k + 1].timestamp - truth[k - 1].timestamp);
    const Eigen::Vector3d v_error = e.velocity_world - v;
    velocity += ratio2(v_error, Eigen::Vector3d::Constant(e.velocity_sigma));
    velocity_error2 += v_error.squaredNorm();
    axes += 3;
  }
  void print() const {
    if (axes == 0) return;
    std::printf("\n%zu scans, each with its first IMU setting:\n\n", scans.size());
    std::printf(
        "| estimate at the last full ICP frame before the first loss | axes | RMS of error / sigma "
        "|\n");
    std::printf("| --- | --- | --- |\n");
    const auto rms = [&](double sum) { return std::sqrt(sum / axes); };
    std::printf(
        "| gyro bias | %d | %.2f |\n| gravity | %d | %.2f |\n| accelerometer bias | %d | %.2f |\n",
        axes, rms(gyro_bias), axes, rms(gravity), axes, rms(accel_bias));
    std::printf("| velocity | %d | %.2f (RMS error %.1f mm/s per axis) |\n", axes, rms(velocity),
                1000 * rms(velocity_error2));
  }
};
SigmaCheck sigma_check;

Result<Loaded> load(const fs::path& dir, std::string label, long max_frames) {
  SequenceOptions options;
  options.load_color = false;
  auto reader = SequenceReader::open(dir, options);
  if (!reader) return reader.error();
  Loaded l;
  l.label = std::move(label);
  const std::size_t n = max_frames > 0 ? std::min<std::size_t>(reader->frame_count(),
                                                               static_cast<std::size_t>(max_frames))
                                       : reader->frame_count();
  for (std::size_t i = 0; i < n; ++i) {
    auto f = reader->next();
    if (!f) return f.error();
    l.frames.push_back(std::move(*f));
  }
  l.reader.emplace(std::move(*reader));
  return l;
}

// The ATE (mm) of every scan and setting run, for the paired comparison printed at the end.
struct PairedAte {
  std::map<std::string, std::map<std::string, double>> ate;  // scan label -> setting -> mm

  // For each pair of settings run (a listed before b in kSettings), over the scans with both:
  // on how many a is no worse than b, the mean of a - b with its 95 % interval (normal
  // approximation), and a's largest excess over b.
  void print(const Options& opt) const {
    bool header = false;
    for (std::size_t i = 0; i < std::size(kSettings); ++i) {
      for (std::size_t j = i + 1; j < std::size(kSettings); ++j) {
        const std::string a = kSettings[i].name, b = kSettings[j].name;
        if (!wanted(opt, kSettings[i]) || !wanted(opt, kSettings[j])) continue;
        std::vector<double> d;
        std::string worst_scan = "-";
        double worst = -std::numeric_limits<double>::infinity(), worst_rel = 0;
        for (const auto& [label, by] : ate) {
          const auto ia = by.find(a), ib = by.find(b);
          if (ia == by.end() || ib == by.end()) continue;
          d.push_back(ia->second - ib->second);
          if (d.back() > worst) {
            worst = d.back();
            worst_rel = ib->second > 0 ? 100 * d.back() / ib->second : 0;
            worst_scan = label;
          }
        }
        if (d.empty()) continue;
        if (!header) {
          std::printf(
              "\n| setting | against | scans | no worse | mean difference mm (95 %% interval) | "
              "largest excess mm |\n");
          std::printf("| --- | --- | --- | --- | --- | --- |\n");
          header = true;
        }
        // The sample standard deviation of the mean: population std / sqrt(n - 1).
        const ErrorStats stats = compute_error_stats(d);
        const double half = d.size() > 1 ? 1.96 * stats.std / std::sqrt(double(d.size() - 1)) : 0;
        const auto no_worse = std::count_if(d.begin(), d.end(), [](double x) { return x <= 0; });
        std::printf("| %s | %s | %zu | %td | %+.3f (%+.3f to %+.3f) | %+.3f (%+.1f %%, %s) |\n",
                    a.c_str(), b.c_str(), d.size(), no_worse, stats.mean, stats.mean - half,
                    stats.mean + half, worst, worst_rel, worst_scan.c_str());
      }
    }
  }
};
PairedAte paired;

void run_setting(const Loaded& seq, const Setting& setting, const Options& opt) {
  ReconstructorConfig c;
  c.smoothing.retrack_frames = opt.retrack_lost_frames;
  c.smoothing.partial_move_sigma = opt.partial_move_sigma;
  c.smoothing.retracked_frame_sigma = opt.retracked_frame_sigma;
  c.recovery.agreement_distance = opt.recovery_agreement_distance;
  c.recovery.correct_velocity = opt.correct_velocity_after_loss;
  c.icp.reliability.max_condition = opt.max_condition;
  if (opt.seed_gate > 0) {
    c.imu.seed_gate = true;
    c.icp.seed_gate_sigmas = opt.seed_gate;
    c.icp.seed_gate_hold_sigmas = std::min(c.icp.seed_gate_hold_sigmas, opt.seed_gate);
  }
  c.intrinsics = *seq.reader->intrinsics();
  c.intrinsics.width = seq.frames.front().depth.width;
  c.intrinsics.height = seq.frames.front().depth.height;
  c.imu.enabled = setting.imu && seq.reader->has_imu();
  c.icp.max_total_iterations = setting.iterations;
  c.inertial.T_camera_imu = seq.reader->T_camera_imu();
  auto rec = Reconstructor::create(c);
  if (!rec) {
    std::fprintf(stderr, "%s: %s\n", seq.label.c_str(), rec.error().describe().c_str());
    return;
  }
  std::vector<FrameResult> results;
  for (const Frame& f : seq.frames) {
    auto r = rec->track_and_fuse(f.timestamp, f.depth, nullptr, f.imu);
    if (!r) {
      std::fprintf(stderr, "%s %s: %s\n", seq.label.c_str(), setting.name,
                   r.error().describe().c_str());
      return;
    }
    results.push_back(std::move(*r));
  }
  auto placed = rec->finish();
  if (!placed) {
    std::fprintf(stderr, "%s %s: %s\n", seq.label.c_str(), setting.name,
                 placed.error().describe().c_str());
    return;
  }
  if (!results.empty()) results.back().retracked += *placed;
  if (setting.imu) sigma_check.add(seq, results);
  const ScanStatistics s = summarize_scan(results);
  double ate_mm = -1;
  if (seq.reader->has_ground_truth()) {
    if (auto ate = evaluate_ate(seq.reader->ground_truth(), rec->trajectory()); ate) {
      ate_mm = 1000 * ate->stats.rmse;
      paired.ate[seq.label][setting.name] = ate_mm;
    }
  }
  std::string after = "-";
  if (seq.hard_end) {
    bool all = true;
    for (const FrameResult& r : results)
      if (r.timestamp > *seq.hard_end && r.status != TrackingStatus::kTracking) all = false;
    after = all ? "yes" : "no";
  }
  std::string recover;
  for (std::size_t k : s.recovery_frames)
    recover += (recover.empty() ? "" : "/") + std::to_string(k);
  std::printf(
      "| %s | %s | %.3f | %zu | %zu | %zu | %zu | %s | %zu | %zu | %.1f | %.1f | %.2f | %s | %.1f "
      "|\n",
      seq.label.c_str(), setting.name, ate_mm, s.lost, s.recovering, s.recoveries,
      s.broken_recoveries, recover.empty() ? "-" : recover.c_str(), s.retracked,
      s.recovery_restarts, s.median_icp_iterations, s.median_icp_iterations_tracking,
      s.mean_icp_iterations, after.c_str(), s.fps);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, opt)) {
    std::cerr
        << "usage: scan_claims [--scenes room,wall,fast] [--seeds 101,102] [--size WxH] [--frames "
           "N]\n"
           "                   [--sequence DIR [--sequence-frames N]] [--settings "
           "imu-1,imu-2,icp-10,icp-30]\n"
           "                   [--retrack-lost-frames N] [--max-condition K] [--seed-gate SIGMAS]\n"
           "                   [--partial-move-sigma M] [--retracked-frame-sigma M]\n"
           "                   [--recovery-agreement-distance M] [--correct-velocity-after-loss "
           "0|1]\n"
           "                   [--work DIR]\n";
    return 2;
  }
  std::printf(
      "| scan | setting | ATE mm | lost | recovering | recoveries | broken | frames to recover | "
      "placed backward | restarts | median it | median it tracking | mean it | all tracking after "
      "the stretch | fps |\n");
  std::printf(
      "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- "
      "|\n");
  for (const std::string& name : opt.scenes) {
    const auto kind = synth::parse_scene_kind(name);
    if (!kind) {
      std::cerr << "unknown scene " << name << "\n";
      return 2;
    }
    for (std::uint64_t seed : opt.seeds) {
      synth::SynthConfig config;
      config.scene = *kind;
      config.seed = seed;
      config.width = opt.width;
      config.height = opt.height;
      config.frames = opt.frames;
      config.color = false;
      const fs::path dir =
          opt.work / (name + "_" + std::to_string(seed) + "_" + std::to_string(opt.width) + "x" +
                      std::to_string(opt.height) + "_" + std::to_string(opt.frames));
      if (!fs::exists(dir / "info.txt")) {
        if (auto s = synth::synthesize(config, dir); !s) {
          std::cerr << s.error().describe() << "\n";
          return 1;
        }
      }
      auto seq = load(dir, name + " " + std::to_string(seed), -1);
      if (!seq) {
        std::cerr << seq.error().describe() << "\n";
        return 1;
      }
      const synth::CameraMotion motion(*kind, seed, config.start_time);
      if (*kind == synth::SceneKind::kWall)
        seq->hard_end = config.start_time + motion.episode_end();
      if (config.imu_noise) seq->bias = synth::draw_imu_bias(seed);
      for (const Setting& setting : kSettings)
        if (wanted(opt, setting)) run_setting(*seq, setting, opt);
    }
  }
  if (!opt.sequence.empty()) {
    auto seq = load(opt.sequence, opt.sequence.filename().string(), opt.sequence_frames);
    if (!seq) {
      std::cerr << seq.error().describe() << "\n";
      return 1;
    }
    for (const Setting& setting : kSettings)
      if (wanted(opt, setting)) run_setting(*seq, setting, opt);
  }
  paired.print(opt);
  sigma_check.print();
  return 0;
}

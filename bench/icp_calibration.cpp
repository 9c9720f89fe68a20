// icp_calibration: measures the ICP quality metrics on synthetic frame pairs where ICP lands
// within 1 cm / 1 deg of ground truth ("good") and where it does not, and chooses the
// reliable/unreliable thresholds from them.
//
// A pair counts as good only when ICP lands within 1 cm / 1 deg from its start AND the
// registration is constrained by the data: ICP started from the truth displaced by 2 cm / 2 deg
// (a random direction) also lands within 1 cm / 1 deg. Without the second condition, a flat wall
// "lands" whenever its start happens to be right, which says nothing about reliability.
//
// Pairs come from the room, wall and fast scenes over many seeds (none used by the tests),
// with frame gaps of 1, 2 and 4 frames at 30 Hz and three kinds of start: identity (no IMU),
// the truth perturbed by up to 3 deg / 3 cm (an IMU-like seed) and by 10-20 deg / 10-30 cm
// (a wrong start). Thresholds are chosen on the odd seeds (maximum recall of good pairs, then
// maximum precision, at a precision of at least --precision among pairs called reliable) and
// reported on the even seeds.
//
//   icp_calibration [--seeds N] [--pairs N] [--size WxH] [--precision P] [--csv FILE]

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "imufusion/icp.hpp"
#include "imufusion/synth.hpp"

using namespace imufusion;

namespace {

struct Sample {
  std::string scene, start;
  int seed = 0;
  double t = 0;
  int gap = 0;
  IcpQuality q;
  double err_t = 0, err_r = 0;
  bool good = false;
};

// A candidate rule: the library's thresholds (min_inliers at its default), judged by judge_icp.
IcpReliabilityThresholds rule(double max_condition, double max_rpw, double min_fraction,
                              double min_pixel_fraction) {
  IcpReliabilityThresholds t;
  t.max_condition = max_condition;
  t.max_residual_per_weight = max_rpw;
  t.min_inlier_fraction = min_fraction;
  t.min_pixel_fraction = min_pixel_fraction;
  return t;
}

struct Score {
  int tp = 0, fp = 0, fn = 0, tn = 0;
  double precision() const { return tp + fp > 0 ? double(tp) / (tp + fp) : 1.0; }
  double recall() const { return tp + fn > 0 ? double(tp) / (tp + fn) : 1.0; }
};

Score score(const std::vector<Sample>& samples, const IcpReliabilityThresholds& rule, int parity) {
  Score s;
  for (const Sample& x : samples) {
    if (parity >= 0 && x.seed % 2 != parity) continue;
    const bool r = judge_icp(x.q, rule, nullptr);
    if (r && x.good) ++s.tp;
    else if (r && !x.good) ++s.fp;
    else if (!r && x.good) ++s.fn;
    else ++s.tn;
  }
  return s;
}

Eigen::Isometry3d perturb(std::mt19937_64& rng, double max_deg, double min_deg, double max_m,
                          double min_m) {
  std::normal_distribution<double> n(0, 1);
  std::uniform_real_distribution<double> u(0, 1);
  Eigen::Vector3d axis(n(rng), n(rng), n(rng));
  Eigen::Vector3d dir(n(rng), n(rng), n(rng));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd((min_deg + (max_deg - min_deg) * u(rng)) * M_PI / 180.0,
                                 axis.normalized()).toRotationMatrix();
  T.translation() = dir.normalized() * (min_m + (max_m - min_m) * u(rng));
  return T;
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 8, pairs = 8, width = 320, height = 240;
  double target_precision = 0.99;
  std::string csv;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--seeds") seeds = std::atoi(v.c_str());
    else if (a == "--pairs") pairs = std::atoi(v.c_str());
    else if (a == "--precision") target_precision = std::atof(v.c_str());
    else if (a == "--csv") csv = v;
    else if (a == "--size" && std::sscanf(v.c_str(), "%dx%d", &width, &height) == 2) {}
    else {
      std::cerr << "usage: icp_calibration [--seeds N] [--pairs N] [--size WxH] [--precision P] [--csv FILE]\n";
      return 2;
    }
  }
  const Intrinsics k = synth::default_intrinsics(width, height);
  IcpConfig config;
  config.reliability = rule(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(), 0.0, 0.0);
  config.reliability.min_inliers = 0;
  auto tracker = IcpTracker::create(config, PreprocessConfig{}, k);
  if (!tracker) {
    std::cerr << tracker.error().describe() << "\n";
    return 1;
  }
  std::cerr << "device: " << tracker->device().name << "\n";

  std::vector<Sample> samples;
  const synth::SensorModel sensor;
  for (int seed = 101; seed < 101 + seeds; ++seed) {
    for (synth::SceneKind kind : {synth::SceneKind::kRoom, synth::SceneKind::kWall, synth::SceneKind::kFast}) {
      const synth::Scene scene = synth::make_scene(kind, static_cast<std::uint64_t>(seed));
      const synth::CameraMotion motion(kind, static_cast<std::uint64_t>(seed));
      std::mt19937_64 rng(static_cast<std::uint64_t>(seed) * 7919u + static_cast<std::uint64_t>(kind));
      std::uniform_real_distribution<double> time(0.5, 9.0);
      for (int p = 0; p < pairs; ++p) {
        double t = time(rng);
        if (kind == synth::SceneKind::kWall && p % 2 == 0) {
          const synth::TimeSpan s = *motion.wall_stretch();
          t = s.begin + (s.end - s.begin) * (time(rng) - 0.5) / 8.5;
        }
        const int gap = std::array<int, 3>{1, 2, 4}[static_cast<std::size_t>(p % 3)];
        const Eigen::Isometry3d T_w_ref = motion.pose_at(t);
        const Eigen::Isometry3d T_w_cur = motion.pose_at(t + gap / 30.0);
        const Eigen::Isometry3d truth = T_w_ref.inverse() * T_w_cur;
        const auto seed_u = static_cast<std::uint64_t>(seed * 1000 + p);
        if (!tracker->set_reference(synth::render_depth(scene, T_w_ref, k, sensor, 2 * seed_u)).ok()) return 1;
        const DepthImage cur = synth::render_depth(scene, T_w_cur, k, sensor, 2 * seed_u + 1);
        auto landed = [&](const Eigen::Isometry3d& estimate, double* err_t, double* err_r) {
          const Eigen::Isometry3d e = truth.inverse() * estimate;
          *err_t = e.translation().norm();
          *err_r = Eigen::AngleAxisd(e.linear()).angle() * 180.0 / M_PI;
          return *err_t < 0.01 && *err_r < 1.0;
        };
        auto probe = tracker->track(cur, truth * perturb(rng, 2, 2, 0.02, 0.02));
        if (!probe) {
          std::cerr << probe.error().describe() << "\n";
          return 1;
        }
        double probe_t = 0, probe_r = 0;
        const bool constrained = landed(probe->T_ref_cur, &probe_t, &probe_r);
        const std::pair<const char*, Eigen::Isometry3d> starts[] = {
            {"identity", Eigen::Isometry3d::Identity()},
            {"imu_like", truth * perturb(rng, 3, 0, 0.03, 0)},
            {"wrong", truth * perturb(rng, 20, 10, 0.3, 0.1)}};
        for (const auto& [name, init] : starts) {
          auto result = tracker->track(cur, init);
          if (!result) {
            std::cerr << result.error().describe() << "\n";
            return 1;
          }
          Sample s;
          s.scene = synth::to_string(kind);
          s.start = name;
          s.seed = seed;
          s.t = t;
          s.gap = gap;
          s.q = result->quality;
          s.good = landed(result->T_ref_cur, &s.err_t, &s.err_r) && constrained;
          samples.push_back(s);
        }
      }
      std::cerr << "seed " << seed << " " << synth::to_string(kind) << ": " << samples.size() << " samples\n";
    }
  }

  if (!csv.empty()) {
    std::ofstream out(csv);
    out << "scene,seed,start,t,gap,good,err_t,err_r_deg,condition,residual_per_weight,inliers,inlier_fraction,pixel_fraction,weight_sum,iterations\n";
    for (const Sample& s : samples)
      out << s.scene << ',' << s.seed << ',' << s.start << ',' << s.t << ',' << s.gap << ',' << s.good << ','
          << s.err_t << ',' << s.err_r << ',' << s.q.condition << ',' << s.q.residual_per_weight << ','
          << s.q.inliers << ',' << s.q.inlier_fraction << ',' << s.q.pixel_fraction << ',' << s.q.weight_sum << ',' << s.q.iterations << '\n';
  }

  // Grid: kappa on a log scale, r/sum(w) on a log scale (m^2), both inlier fractions linear.
  std::vector<double> kappas, rpws, fractions, pixel_fractions;
  for (double e = 1.0; e <= 4.0001; e += 0.125) kappas.push_back(std::pow(10.0, e));
  kappas.push_back(std::numeric_limits<double>::infinity());
  for (double e = -7.0; e <= -3.0001; e += 0.125) rpws.push_back(std::pow(10.0, e));
  rpws.push_back(std::numeric_limits<double>::infinity());
  for (double f = 0.0; f <= 0.80001; f += 0.05) fractions.push_back(f);
  for (double f = 0.0; f <= 0.60001; f += 0.05) pixel_fractions.push_back(f);
  IcpReliabilityThresholds best = rule(kappas.back(), rpws.back(), 0.0, 0.0);
  Score best_score = score(samples, best, 1);
  bool found = false;
  for (double kc : kappas)
    for (double r : rpws)
      for (double f : fractions)
        for (double pf : pixel_fractions) {
          const IcpReliabilityThresholds candidate = rule(kc, r, f, pf);
          const Score s = score(samples, candidate, 1);
          if (s.precision() < target_precision) continue;
          // Highest recall, then highest precision; on a full tie the first in grid order
          // (smallest kappa, r/w and fractions).
          if (!found || s.recall() > best_score.recall() ||
              (s.recall() == best_score.recall() && s.precision() > best_score.precision())) {
            best = candidate;
            best_score = s;
            found = true;
          }
        }

  int good = 0;
  for (const Sample& s : samples) good += s.good ? 1 : 0;
  auto report = [&](const char* name, const IcpReliabilityThresholds& t) {
    const Score cal = score(samples, t, 1), test = score(samples, t, 0);
    std::printf("%-26s kappa <= %-9.4g r/sum(w) <= %-9.3g inlier fraction >= %.2f pixel fraction >= %.2f\n",
                name, t.max_condition, t.max_residual_per_weight, t.min_inlier_fraction, t.min_pixel_fraction);
    std::printf("%-26s calibration seeds: precision %.3f recall %.3f | held-out seeds: precision %.3f recall %.3f (tp %d fp %d fn %d tn %d)\n",
                "", cal.precision(), cal.recall(), test.precision(), test.recall(), test.tp, test.fp, test.fn, test.tn);
  };
  std::printf("device %s, %dx%d, %zu pairs (%d good: within 1 cm / 1 deg, and constrained)\n", tracker->device().name.c_str(),
              width, height, samples.size(), good);
  for (const char* scene : {"room", "wall", "fast"})
    for (const char* start : {"identity", "imu_like", "wrong"}) {
      int n = 0, g = 0;
      for (const Sample& s : samples)
        if (s.scene == scene && s.start == start) {
          ++n;
          g += s.good ? 1 : 0;
        }
      std::printf("  %-5s start %-9s %3d pairs, %3d good\n", scene, start, n, g);
    }
  report("literature (VoxelHashing)", rule(150.0, 1.5, 0.0, 0.0));
  const IcpReliabilityThresholds defaults;
  report("defaults", defaults);
  if (found) report("chosen", best);
  else std::printf("no rule reaches precision %.3f on the calibration seeds\n", target_precision);
  // The pixel fraction at the other defaults: kappa is set by whole wall scans (bench/README.md),
  // and scans starting before a far room pair only 37-40 % of their pixels when aligned.
  for (double pf : {0.0, 0.25, 0.30, 0.35, 0.40, 0.45}) {
    const std::string name = "defaults, pixel fr. " + std::to_string(pf).substr(0, 4);
    IcpReliabilityThresholds t = defaults;
    t.min_pixel_fraction = pf;
    report(name.c_str(), t);
  }
  return 0;
}

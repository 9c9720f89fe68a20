// icp_calibration: measures the ICP quality metrics on frame pairs where ICP lands within
// 1 cm / 1 deg of ground truth ("good") and where it does not, chooses the reliable/unreliable
// thresholds from the project's own generator, and reports the precision and recall of the
// reliability decision separately for each source: the own generator and any recorded
// sequences with ground truth (another renderer's scans, real recordings).
//
// A pair counts as good only when ICP lands within 1 cm / 1 deg from its start AND the
// registration is constrained by the data: ICP started from the truth displaced by 2 cm / 2 deg
// (a random direction) also lands within 1 cm / 1 deg. Without the second condition, a flat wall
// "lands" whenever its start happens to be right, which says nothing about reliability.
//
// Own generator: pairs from the room, wall and fast scenes over many seeds (none used by the
// tests). Sequences (--sequence DIR, repeatable): --sequence-pairs reference frames spread over
// the recording. Both with frame gaps of 1, 2 and 4 frames at 30 Hz and three kinds of start:
// identity (no IMU), the truth perturbed by up to 3 deg / 3 cm (an IMU-like seed) and by
// 10-20 deg / 10-30 cm (a wrong start). Thresholds are chosen on the own generator's odd seeds
// (maximum recall of good pairs, then maximum precision, at a precision of at least
// --precision among pairs called reliable) and reported on its even seeds and on every sequence.
//
// Two decisions are reported per source: the fixed thresholds (IcpReliabilityThresholds) and
// the scanner's, which follows the frame and the scan: the residual test widened to twice the
// frame's mean depth noise variance (IcpConfig::depth_noise) as far as the source's earlier
// IMU-like pairs that passed show that noise (TrackingConfig::residual_ratio), the pairing tests
// lowered to what those pairs paired (PairingReference, TrackingConfig).
// Frame pairs are noisier than the scanner's frame-to-model alignment, so these figures bound
// the scanner's decision from below.
//
//   icp_calibration [--seeds N] [--pairs N] [--size WxH] [--precision P] [--csv FILE]
//                   [--sequence DIR]... [--sequence-pairs N] [--from-csv FILE]
//                   [--residual-ratio R]   (the scanner's TrackingConfig::residual_ratio; 0: off)

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "imufusion/icp.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"
#include "imufusion/tracking.hpp"
#include "imufusion/trajectory.hpp"

using namespace imufusion;

namespace {

struct Sample {
  std::string source, scene, start;
  int seed = 0;  // own generator: the scene seed (odd: calibration, even: held out); sequences: 0
  double t = 0;
  int gap = 0;
  IcpQuality q;
  double noise_variance = 0;  // mean sigma(z)^2 over the current frame's valid depths, m^2
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
  void add(bool reliable, bool good) {
    if (reliable && good)
      ++tp;
    else if (reliable)
      ++fp;
    else if (good)
      ++fn;
    else
      ++tn;
  }
};

// `parity` >= 0: own-generator samples of that seed parity only; `source` non-empty: that source.
// `start` non-empty: pairs from that kind of start only.
Score score(const std::vector<Sample>& samples, const IcpReliabilityThresholds& rule, int parity,
            const std::string& source = "own", const std::string& start = "") {
  Score s;
  for (const Sample& x : samples) {
    if (x.source != source || (parity >= 0 && x.seed % 2 != parity) ||
        (!start.empty() && x.start != start))
      continue;
    s.add(judge_icp(x.q, rule, nullptr), x.good);
  }
  return s;
}

// The scanner's decision over one source's samples in time order: the residual test widened to
// the frame's depth noise as far as the source's earlier IMU-like pairs that passed show it
// (`residual_ratio`, TrackingConfig; 0: widened to the noise model), the pairing tests lowered to
// what those pairs paired. `start` non-empty: counts the pairs from that kind of start only.
Score score_adaptive(const std::vector<Sample>& samples, const std::string& source,
                     const std::string& start = "",
                     double residual_ratio = TrackingConfig{}.residual_ratio) {
  Score s;
  TrackingConfig config;
  config.residual_ratio = residual_ratio;
  PairingReference pairing(config);
  const IcpReliabilityThresholds fixed;
  for (const Sample& x : samples) {
    if (x.source != source) continue;
    IcpReliabilityThresholds t = fixed.widened_to_noise(x.noise_variance);
    t.max_residual_per_weight = pairing.residual_limit(fixed.max_residual_per_weight,
                                                       t.max_residual_per_weight, x.noise_variance);
    pairing.apply(t.min_inlier_fraction, t.min_pixel_fraction);
    const bool reliable = judge_icp(x.q, t, nullptr);
    if (start.empty() || x.start == start) s.add(reliable, x.good);
    if (reliable && x.start == "imu_like") {
      pairing.add(x.q.inlier_fraction, x.q.pixel_fraction);
      pairing.add_residual(x.q.residual_per_weight, x.noise_variance);
    }
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
  T.linear() =
      Eigen::AngleAxisd((min_deg + (max_deg - min_deg) * u(rng)) * M_PI / 180.0, axis.normalized())
          .toRotationMatrix();
  T.translation() = dir.normalized() * (min_m + (max_m - min_m) * u(rng));
  return T;
}

// One frame pair: the constrained probe, then ICP from each kind of start. `base` labels the
// samples (source, scene, seed, t, gap). False on a device error (printed).
bool measure_pair(IcpTracker& tracker, const DepthImage& ref, const DepthImage& cur,
                  const Eigen::Isometry3d& truth, std::mt19937_64& rng, const Sample& base,
                  const IcpConfig& config, std::vector<Sample>& samples) {
  if (const Status st = tracker.set_reference(ref); !st.ok()) {
    std::cerr << st.error().describe() << "\n";
    return false;
  }
  auto landed = [&](const Eigen::Isometry3d& estimate, double* err_t, double* err_r) {
    const Eigen::Isometry3d e = truth.inverse() * estimate;
    *err_t = e.translation().norm();
    *err_r = Eigen::AngleAxisd(e.linear()).angle() * 180.0 / M_PI;
    return *err_t < 0.01 && *err_r < 1.0;
  };
  auto probe = tracker.track(cur, truth * perturb(rng, 2, 2, 0.02, 0.02));
  if (!probe) {
    std::cerr << probe.error().describe() << "\n";
    return false;
  }
  double probe_t = 0, probe_r = 0;
  const bool constrained = landed(probe->T_ref_cur, &probe_t, &probe_r);
  const PreprocessConfig range;  // the depths preprocessing keeps, as the scanner's residual test
  const double noise_variance =
      config.depth_noise.mean_variance(cur, range.min_depth, range.max_depth);
  const std::pair<const char*, Eigen::Isometry3d> starts[] = {
      {"identity", Eigen::Isometry3d::Identity()},
      {"imu_like", truth * perturb(rng, 3, 0, 0.03, 0)},
      {"wrong", truth * perturb(rng, 20, 10, 0.3, 0.1)}};
  for (const auto& [name, init] : starts) {
    auto result = tracker.track(cur, init);
    if (!result) {
      std::cerr << result.error().describe() << "\n";
      return false;
    }
    Sample s = base;
    s.start = name;
    s.q = result->quality;
    s.noise_variance = noise_variance;
    s.good = landed(result->T_ref_cur, &s.err_t, &s.err_r) && constrained;
    samples.push_back(s);
  }
  return true;
}

// The own generator's pairs: room, wall and fast scenes, seeds 101 .. 100 + seeds.
bool own_generator_samples(IcpTracker& tracker, const Intrinsics& k, int seeds, int pairs,
                           const IcpConfig& config, std::vector<Sample>& samples) {
  const synth::SensorModel sensor;
  for (int seed = 101; seed < 101 + seeds; ++seed) {
    for (synth::SceneKind kind :
         {synth::SceneKind::kRoom, synth::SceneKind::kWall, synth::SceneKind::kFast}) {
      const synth::Scene scene = synth::make_scene(kind, static_cast<std::uint64_t>(seed));
      const synth::CameraMotion motion(kind, static_cast<std::uint64_t>(seed));
      std::mt19937_64 rng(static_cast<std::uint64_t>(seed) * 7919u +
                          static_cast<std::uint64_t>(kind));
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
        const auto seed_u = static_cast<std::uint64_t>(seed * 1000 + p);
        const DepthImage ref = synth::render_depth(scene, T_w_ref, k, sensor, 2 * seed_u);
        const DepthImage cur = synth::render_depth(scene, T_w_cur, k, sensor, 2 * seed_u + 1);
        Sample base;
        base.source = "own";
        base.scene = synth::to_string(kind);
        base.seed = seed;
        base.t = t;
        base.gap = gap;
        if (!measure_pair(tracker, ref, cur, T_w_ref.inverse() * T_w_cur, rng, base, config,
                          samples))
          return false;
      }
      std::cerr << "seed " << seed << " " << synth::to_string(kind) << ": " << samples.size()
                << " samples\n";
    }
  }
  return true;
}

// A recorded sequence's pairs: `pairs` reference frames spread evenly over it (time order), gaps
// of 1, 2 and 4 frames, truth from groundtruth.txt (frames without a pose within 20 ms skipped).
bool sequence_samples(const std::filesystem::path& dir, int pairs, const IcpConfig& config,
                      std::vector<Sample>& samples) {
  auto reader = SequenceReader::open(dir);
  if (!reader) {
    std::cerr << reader.error().describe() << "\n";
    return false;
  }
  if (!reader->has_ground_truth() || !reader->intrinsics() || reader->frame_count() < 8) {
    std::cerr << dir << ": needs ground truth, intrinsics and at least 8 frames\n";
    return false;
  }
  auto tracker = IcpTracker::create(config, PreprocessConfig{}, *reader->intrinsics());
  if (!tracker) {
    std::cerr << tracker.error().describe() << "\n";
    return false;
  }
  const std::string source =
      dir.filename().empty() ? dir.parent_path().filename().string() : dir.filename().string();
  std::mt19937_64 rng(std::hash<std::string>{}(source));
  const std::vector<double> stamps = reader->timestamps();
  const std::size_t n = stamps.size() - 4;
  for (int p = 0; p < pairs; ++p) {
    const int gap = std::array<int, 3>{1, 2, 4}[static_cast<std::size_t>(p % 3)];
    const std::size_t i = static_cast<std::size_t>(p) * n / static_cast<std::size_t>(pairs);
    const StampedPose* a = find_pose(reader->ground_truth(), stamps[i]);
    const StampedPose* b =
        find_pose(reader->ground_truth(), stamps[i + static_cast<std::size_t>(gap)]);
    if (a == nullptr || b == nullptr) continue;
    auto ref = reader->frame(i);
    auto cur = reader->frame(i + static_cast<std::size_t>(gap));
    if (!ref || !cur) {
      std::cerr << (ref ? cur.error() : ref.error()).describe() << "\n";
      return false;
    }
    Sample base;
    base.source = source;
    base.scene = source;
    base.t = stamps[i];
    base.gap = gap;
    if (!measure_pair(*tracker, ref->depth, cur->depth,
                      a->T_world_camera.inverse() * b->T_world_camera, rng, base, config, samples))
      return false;
  }
  std::cerr << source << ": " << samples.size() << " samples in all\n";
  return true;
}

void write_csv(const std::string& path, const std::vector<Sample>& samples) {
  std::ofstream out(path);
  out << "source,scene,seed,start,t,gap,good,err_t,err_r_deg,condition,residual_per_weight,inliers,"
         "inlier_fraction,"
         "pixel_fraction,weight_sum,iterations,noise_variance\n";
  for (const Sample& s : samples)
    out << s.source << ',' << s.scene << ',' << s.seed << ',' << s.start << ',' << s.t << ','
        << s.gap << ',' << s.good << ',' << s.err_t << ',' << s.err_r << ',' << s.q.condition << ','
        << s.q.residual_per_weight << ',' << s.q.inliers << ',' << s.q.inlier_fraction << ','
        << s.q.pixel_fraction << ',' << s.q.weight_sum << ',' << s.q.iterations << ','
        << s.noise_variance << '\n';
}

// Samples written by write_csv (--csv), to report on them again without measuring.
bool read_csv(const std::string& path, std::vector<Sample>& samples) {
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line)) {
    std::cerr << path << ": cannot read\n";
    return false;
  }
  int number = 1;
  while (std::getline(in, line)) {
    ++number;
    std::vector<std::string> f;
    std::stringstream fields(line);
    for (std::string field; std::getline(fields, field, ',');) f.push_back(field);
    if (f.size() != 17) {
      std::cerr << path << ":" << number << ": expected 17 fields, got " << f.size() << "\n";
      return false;
    }
    Sample s;
    s.source = f[0];
    s.scene = f[1];
    s.seed = std::atoi(f[2].c_str());
    s.start = f[3];
    s.t = std::atof(f[4].c_str());
    s.gap = std::atoi(f[5].c_str());
    s.good = f[6] == "1";
    s.err_t = std::atof(f[7].c_str());
    s.err_r = std::atof(f[8].c_str());
    s.q.condition = std::atof(f[9].c_str());
    s.q.residual_per_weight = std::atof(f[10].c_str());
    s.q.inliers = std::atoll(f[11].c_str());
    s.q.inlier_fraction = std::atof(f[12].c_str());
    s.q.pixel_fraction = std::atof(f[13].c_str());
    s.q.weight_sum = std::atof(f[14].c_str());
    s.q.iterations = std::atoi(f[15].c_str());
    s.noise_variance = std::atof(f[16].c_str());
    samples.push_back(s);
  }
  return true;
}

// The rule of highest recall (then precision) at `target_precision` on the own generator's odd
// seeds, over a grid: kappa and r/sum(w) on log scales, both inlier fractions linear.
std::optional<IcpReliabilityThresholds> choose_rule(const std::vector<Sample>& samples,
                                                    double target_precision) {
  std::vector<double> kappas, rpws, fractions, pixel_fractions;
  for (double e = 1.0; e <= 4.0001; e += 0.125) kappas.push_back(std::pow(10.0, e));
  kappas.push_back(std::numeric_limits<double>::infinity());
  for (double e = -7.0; e <= -3.0001; e += 0.125) rpws.push_back(std::pow(10.0, e));
  rpws.push_back(std::numeric_limits<double>::infinity());
  for (double f = 0.0; f <= 0.80001; f += 0.05) fractions.push_back(f);
  for (double f = 0.0; f <= 0.60001; f += 0.05) pixel_fractions.push_back(f);
  std::optional<IcpReliabilityThresholds> best;
  Score best_score;
  for (double kc : kappas)
    for (double r : rpws)
      for (double f : fractions)
        for (double pf : pixel_fractions) {
          const IcpReliabilityThresholds candidate = rule(kc, r, f, pf);
          const Score s = score(samples, candidate, 1);
          if (s.precision() < target_precision) continue;
          // Highest recall, then highest precision; on a full tie the first in grid order.
          if (!best || s.recall() > best_score.recall() ||
              (s.recall() == best_score.recall() && s.precision() > best_score.precision())) {
            best = candidate;
            best_score = s;
          }
        }
  return best;
}

void print_score(const char* what, const Score& s) {
  std::printf("  %-34s precision %.3f recall %.3f (tp %d fp %d fn %d tn %d)\n", what, s.precision(),
              s.recall(), s.tp, s.fp, s.fn, s.tn);
}

void report(const std::vector<Sample>& samples, std::optional<IcpReliabilityThresholds> chosen,
            double residual_ratio, const std::vector<std::string>& sources) {
  auto describe = [](const char* name, const IcpReliabilityThresholds& t) {
    std::printf(
        "%-26s kappa <= %-9.4g r/sum(w) <= %-9.3g inlier fraction >= %.2f pixel fraction >= %.2f\n",
        name, t.max_condition, t.max_residual_per_weight, t.min_inlier_fraction,
        t.min_pixel_fraction);
  };
  const IcpReliabilityThresholds defaults;
  describe("literature (VoxelHashing)", rule(150.0, 1.5, 0.0, 0.0));
  print_score("own generator, held-out seeds", score(samples, rule(150.0, 1.5, 0.0, 0.0), 0));
  describe("defaults", defaults);
  print_score("own generator, calibration seeds", score(samples, defaults, 1));
  print_score("own generator, held-out seeds", score(samples, defaults, 0));
  if (chosen) {
    describe("chosen", *chosen);
    print_score("own generator, calibration seeds", score(samples, *chosen, 1));
    print_score("own generator, held-out seeds", score(samples, *chosen, 0));
  }
  // The pixel fraction at the other defaults: kappa is set by whole wall scans (bench/README.md),
  // and scans starting before a far room pair only 37-40 % of their pixels when aligned.
  for (double pf : {0.0, 0.25, 0.30, 0.35, 0.40, 0.45}) {
    IcpReliabilityThresholds t = defaults;
    t.min_pixel_fraction = pf;
    std::printf("defaults, pixel fraction >= %.2f\n", pf);
    print_score("own generator, held-out seeds", score(samples, t, 0));
  }
  std::printf(
      "per source (fixed: the defaults; scanner: noise-widened residual within the residual "
      "reference, pairing reference; noise model only: the residual widened to the noise "
      "model alone):\n");
  for (const std::string& source : sources) {
    int n = 0, good = 0;
    for (const Sample& s : samples)
      if (s.source == source) {
        ++n;
        good += s.good ? 1 : 0;
      }
    std::printf(" %s: %d pairs, %d good\n", source.c_str(), n, good);
    print_score("fixed thresholds", score(samples, defaults, -1, source));
    print_score("scanner's decision", score_adaptive(samples, source, "", residual_ratio));
    print_score("scanner's, noise model only", score_adaptive(samples, source, "", 0));
    print_score("fixed, IMU-like starts", score(samples, defaults, -1, source, "imu_like"));
    print_score("scanner's, IMU-like starts",
                score_adaptive(samples, source, "imu_like", residual_ratio));
    print_score("scanner's, IMU-like, noise model only",
                score_adaptive(samples, source, "imu_like", 0));
  }
}

// Measures the own generator's pairs and each sequence's: the device's name and the samples.
std::optional<std::pair<std::string, std::vector<Sample>>> measure(
    int seeds, int pairs, int width, int height, int sequence_pairs,
    const std::vector<std::filesystem::path>& sequences) {
  const Intrinsics k = synth::default_intrinsics(width, height);
  IcpConfig config;
  config.reliability = rule(std::numeric_limits<double>::infinity(),
                            std::numeric_limits<double>::infinity(), 0.0, 0.0);
  config.reliability.min_inliers = 0;
  auto tracker = IcpTracker::create(config, PreprocessConfig{}, k);
  if (!tracker) {
    std::cerr << tracker.error().describe() << "\n";
    return std::nullopt;
  }
  std::cerr << "device: " << tracker->device().name << "\n";
  std::vector<Sample> samples;
  if (!own_generator_samples(*tracker, k, seeds, pairs, config, samples)) return std::nullopt;
  for (const auto& dir : sequences)
    if (!sequence_samples(dir, sequence_pairs, config, samples)) return std::nullopt;
  return std::make_pair(tracker->device().name, std::move(samples));
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 8, pairs = 8, width = 320, height = 240, sequence_pairs = 60;
  double target_precision = 0.99;
  double residual_ratio = TrackingConfig{}.residual_ratio;
  std::string csv, from_csv;
  std::vector<std::filesystem::path> sequences;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--seeds")
      seeds = std::atoi(v.c_str());
    else if (a == "--pairs")
      pairs = std::atoi(v.c_str());
    else if (a == "--precision")
      target_precision = std::atof(v.c_str());
    else if (a == "--residual-ratio")
      residual_ratio = std::atof(v.c_str());
    else if (a == "--csv")
      csv = v;
    else if (a == "--from-csv")
      from_csv = v;
    else if (a == "--sequence")
      sequences.emplace_back(v);
    else if (a == "--sequence-pairs")
      sequence_pairs = std::atoi(v.c_str());
    else if (a == "--size" && std::sscanf(v.c_str(), "%dx%d", &width, &height) == 2) {
    } else {
      std::cerr
          << "usage: icp_calibration [--seeds N] [--pairs N] [--size WxH] [--precision P] [--csv "
             "FILE]\n"
             "                       [--sequence DIR]... [--sequence-pairs N] [--from-csv FILE]\n"
             "                       [--residual-ratio R]\n";
      return 2;
    }
  }
  std::vector<Sample> samples;
  std::string device = "(from " + from_csv + ")";
  if (from_csv.empty()) {
    auto measured = measure(seeds, pairs, width, height, sequence_pairs, sequences);
    if (!measured) return 1;
    device = measured->first;
    samples = std::move(measured->second);
  } else if (!read_csv(from_csv, samples)) {
    return 1;
  }
  std::vector<std::string> sources;
  for (const Sample& s : samples)
    if (std::find(sources.begin(), sources.end(), s.source) == sources.end())
      sources.push_back(s.source);
  if (!csv.empty()) write_csv(csv, samples);

  int good = 0;
  for (const Sample& s : samples) good += s.good ? 1 : 0;
  std::printf(
      "device %s, own generator at %dx%d, %zu pairs (%d good: within 1 cm / 1 deg, and "
      "constrained)\n",
      device.c_str(), width, height, samples.size(), good);
  for (const char* scene : {"room", "wall", "fast"})
    for (const char* start : {"identity", "imu_like", "wrong"}) {
      int n = 0, g = 0;
      for (const Sample& s : samples)
        if (s.source == "own" && s.scene == scene && s.start == start) {
          ++n;
          g += s.good ? 1 : 0;
        }
      std::printf("  %-5s start %-9s %3d pairs, %3d good\n", scene, start, n, g);
    }
  const auto chosen = choose_rule(samples, target_precision);
  if (!chosen)
    std::printf("no rule reaches precision %.3f on the calibration seeds\n", target_precision);
  report(samples, chosen, residual_ratio, sources);
  return 0;
}

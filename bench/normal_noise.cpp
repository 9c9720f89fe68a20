// normal_noise: how far apart the normals of one surface point fall in two frames of a sequence
// with ground truth, by depth. Each pixel of frame t+step with a vertex and a normal is moved into
// frame t by the ground-truth motion and paired with the pixel it projects onto, if their points
// lie within 3 sigma(z) + 5 mm of each other (one surface); the angle between the two normals is
// then recorded with the pixel's depth. Both normals carry the preprocessing's noise, so a frame's
// angle to a model normal (smoothed by fusion) is about 1/sqrt(2) of it.
//
// It prints, per depth bin, percentiles of the angle and of k = tan(angle) z / (f sigma(z)), the
// angle in units of the depth noise over one pixel's footprint (DepthNoiseModel, the default), so
// sequences from different sensors and generators can be compared on one scale; and the pooled
// percentiles of k over all pairs at each pyramid level.
//
//   normal_noise SEQUENCE [--pairs N] [--step S]

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "imufusion/icp.hpp"
#include "imufusion/preprocess.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/trajectory.hpp"

using namespace imufusion;

namespace {

struct Sample {
  float z = 0, angle_deg = 0, k = 0;
};

double percentile(std::vector<float> v, double p) {
  if (v.empty()) return NAN;
  const auto i = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(i), v.end());
  return v[i];
}

// Pairs level `level` of frame b (moved by T_a_b) with frame a's pixels.
void pair_level(const PreprocessedFrame& a, const PreprocessedFrame& b, const Intrinsics& k,
                int level, const Eigen::Isometry3d& T_a_b, const DepthNoiseModel& noise,
                std::vector<Sample>& out) {
  const Vec4Image& va = a.vertices[level];
  const Vec4Image& na = a.normals[level];
  const Vec4Image& vb = b.vertices[level];
  const Vec4Image& nb = b.normals[level];
  const Intrinsics kl = k.at_level(level);
  const Eigen::Matrix3d R = T_a_b.linear();
  for (std::size_t i = 0; i < vb.data.size(); ++i) {
    if (vb.data[i].w() <= 0.5f || nb.data[i].w() <= 0.5f) continue;
    const Eigen::Vector3d p = R * vb.data[i].head<3>().cast<double>() + T_a_b.translation();
    if (p.z() <= 0) continue;
    const long u = std::lround(kl.fx * p.x() / p.z() + kl.cx);
    const long v = std::lround(kl.fy * p.y() / p.z() + kl.cy);
    if (u < 0 || v < 0 || u >= kl.width || v >= kl.height) continue;
    const std::size_t j = static_cast<std::size_t>(v) * static_cast<std::size_t>(kl.width) +
                          static_cast<std::size_t>(u);
    if (va.data[j].w() <= 0.5f || na.data[j].w() <= 0.5f) continue;
    const double z = p.z();
    const double sigma = noise.sigma(z);
    if ((va.data[j].head<3>().cast<double>() - p).norm() > 3 * sigma + 0.005) continue;
    const Eigen::Vector3d m = R * nb.data[i].head<3>().cast<double>();
    const double cosine = std::clamp(m.dot(na.data[j].head<3>().cast<double>()), -1.0, 1.0);
    const double angle = std::acos(cosine);
    out.push_back({static_cast<float>(z), static_cast<float>(angle * 180 / M_PI),
                   static_cast<float>(std::tan(std::min(angle, 1.5)) * z / (kl.fx * sigma))});
  }
}

void print_report(const std::vector<std::vector<Sample>>& levels) {
  std::printf("level 0 by depth: bin (m), pairs, angle p50/p90/p95 (deg), k p50/p90/p95\n");
  for (double lo = 0.5; lo < 5.0; lo += 0.5) {
    std::vector<float> angle, k;
    for (const Sample& s : levels[0])
      if (s.z >= lo && s.z < lo + 0.5) {
        angle.push_back(s.angle_deg);
        k.push_back(s.k);
      }
    if (angle.size() < 100) continue;
    std::printf("  %.1f-%.1f %9zu  %5.1f %5.1f %5.1f   %5.2f %5.2f %5.2f\n", lo, lo + 0.5,
                angle.size(), percentile(angle, 0.5), percentile(angle, 0.9),
                percentile(angle, 0.95), percentile(k, 0.5), percentile(k, 0.9),
                percentile(k, 0.95));
  }
  for (std::size_t l = 0; l < levels.size(); ++l) {
    std::vector<float> k;
    for (const Sample& s : levels[l]) k.push_back(s.k);
    std::printf("level %zu: %zu pairs, k p50 %.2f p90 %.2f p95 %.2f p99 %.2f\n", l, k.size(),
                percentile(k, 0.5), percentile(k, 0.9), percentile(k, 0.95), percentile(k, 0.99));
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: normal_noise SEQUENCE [--pairs N] [--step S]\n");
    return 2;
  }
  int pairs = 20, step = 1;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--pairs")
      pairs = std::atoi(argv[i + 1]);
    else if (flag == "--step")
      step = std::atoi(argv[i + 1]);
  }
  SequenceOptions options;
  options.load_color = false;
  auto reader = SequenceReader::open(argv[1], options);
  if (!reader) {
    std::fprintf(stderr, "normal_noise: %s\n", reader.error().message.c_str());
    return 1;
  }
  if (!reader->has_ground_truth() || !reader->intrinsics()) {
    std::fprintf(stderr, "normal_noise: %s has no ground truth or no intrinsics\n", argv[1]);
    return 1;
  }
  const Intrinsics k = *reader->intrinsics();
  PreprocessConfig pre;
  auto preprocessor = DepthPreprocessor::create(pre, k);
  if (!preprocessor) {
    std::fprintf(stderr, "normal_noise: %s\n", preprocessor.error().message.c_str());
    return 1;
  }
  const DepthNoiseModel noise;
  std::vector<std::vector<Sample>> levels(static_cast<std::size_t>(pre.levels));
  const std::size_t n = reader->frame_count();
  const std::size_t stride = std::max<std::size_t>(
      1, (n - static_cast<std::size_t>(step)) / static_cast<std::size_t>(pairs));
  for (std::size_t t = 0; t + static_cast<std::size_t>(step) < n; t += stride) {
    auto fa = reader->frame(t);
    auto fb = reader->frame(t + static_cast<std::size_t>(step));
    if (!fa || !fb) continue;
    const StampedPose* pa = find_pose(reader->ground_truth(), fa->timestamp);
    const StampedPose* pb = find_pose(reader->ground_truth(), fb->timestamp);
    if (pa == nullptr || pb == nullptr) continue;
    auto a = preprocessor->process(fa->depth);
    auto b = preprocessor->process(fb->depth);
    if (!a || !b) continue;
    const Eigen::Isometry3d T_a_b = pa->T_world_camera.inverse() * pb->T_world_camera;
    for (int l = 0; l < pre.levels; ++l)
      pair_level(*a, *b, k, l, T_a_b, noise, levels[static_cast<std::size_t>(l)]);
  }
  print_report(levels);
  return 0;
}

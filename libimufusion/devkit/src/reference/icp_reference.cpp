#include "reference/icp_reference.hpp"

#include <cmath>
#include <utility>

namespace imufusion::reference {

std::vector<IcpRow> icp_associate(const Vec4Image& cur_vertices, const Vec4Image& cur_normals,
                                  const Vec4Image& ref_vertices, const Vec4Image& ref_normals,
                                  const Intrinsics& k, const Eigen::Isometry3d& T_ref_cur,
                                  double max_distance, double min_normal_cos,
                                  const DepthNoiseModel& noise, const NormalGate& gate) {
  const double max_noise_cos = std::cos(gate.max_angle_deg * M_PI / 180.0);
  std::vector<IcpRow> rows(cur_vertices.data.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Eigen::Vector4f& v = cur_vertices.data[i];
    const Eigen::Vector4f& n = cur_normals.data[i];
    if (v.w() <= 0 || n.w() <= 0) continue;
    rows[i].valid = true;
    rows[i].z = v.z();
    const Eigen::Vector3d p = T_ref_cur * v.head<3>().cast<double>();
    const Eigen::Vector3d m = T_ref_cur.linear() * n.head<3>().cast<double>();
    if (p.z() <= 0) continue;
    const double u = std::floor(k.fx * p.x() / p.z() + k.cx + 0.5);
    const double w = std::floor(k.fy * p.y() / p.z() + k.cy + 0.5);
    if (u < 0 || w < 0 || u >= ref_vertices.width || w >= ref_vertices.height) continue;
    const Eigen::Vector4f& q4 = ref_vertices.at(static_cast<int>(u), static_cast<int>(w));
    const Eigen::Vector4f& g4 = ref_normals.at(static_cast<int>(u), static_cast<int>(w));
    if (q4.w() <= 0 || g4.w() <= 0) continue;
    rows[i].covered = true;
    const Eigen::Vector3d q = q4.head<3>().cast<double>();
    const Eigen::Vector3d g = g4.head<3>().cast<double>();
    const double dist = (p - q).norm();
    const double cosine = m.dot(g);
    const double tan_noise = gate.noise_k * noise.sigma(v.z()) * k.fx / v.z();
    const double min_cos = std::min(
        min_normal_cos, std::max(1.0 / std::sqrt(1.0 + tan_noise * tan_noise), max_noise_cos));
    if (dist > max_distance || cosine < min_cos) continue;
    IcpRow& row = rows[i];
    row.a << p.cross(g), g;
    row.b = g.dot(q - p);
    row.w = cosine * (1.0 - dist / max_distance);
  }
  return rows;
}

NormalEquations icp_reduce(const std::vector<IcpRow>& rows, const DepthNoiseModel& noise) {
  NormalEquations eq;
  for (const IcpRow& row : rows) {
    if (!row.valid) continue;
    const double information = noise.information(row.z);
    eq.valid_information += information;
    eq.valid_pixels += 1;
    if (!row.covered) {
      eq.uncovered_information += information;
      eq.uncovered_pixels += 1;
    }
    if (row.w <= 0) continue;
    eq.inlier_information += information;
    eq.AtA += row.w * row.a * row.a.transpose();
    eq.Atb += row.w * row.a * row.b;
    eq.btb += row.w * row.b * row.b;
    eq.inliers += 1;
    eq.weight_sum += row.w;
  }
  return eq;
}

CpuNormalEquationSource::CpuNormalEquationSource(PreprocessedFrame reference,
                                                 PreprocessedFrame current,
                                                 const Intrinsics& intrinsics,
                                                 const DepthNoiseModel& noise,
                                                 const NormalGate& gate)
    : reference_(std::move(reference)),
      current_(std::move(current)),
      intrinsics_(intrinsics),
      noise_(noise),
      gate_(gate) {}

Result<NormalEquations> CpuNormalEquationSource::evaluate(int level,
                                                          const Eigen::Isometry3d& T_ref_cur,
                                                          float max_distance,
                                                          float min_normal_cos) {
  const auto l = static_cast<std::size_t>(level);
  const auto rows = icp_associate(current_.vertices[l], current_.normals[l], reference_.vertices[l],
                                  reference_.normals[l], intrinsics_.at_level(level), T_ref_cur,
                                  max_distance, min_normal_cos, noise_, gate_);
  return icp_reduce(rows, noise_);
}

}  // namespace imufusion::reference

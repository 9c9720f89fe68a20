#pragma once
// CPU references of the ICP kernels (shaders/icp_associate.comp, icp_reduce.comp), in double,
// written from the definitions in shaders/include/imufusion_layouts.h; and a NormalEquationSource
// on top of them, so the host ICP can be tested with no GPU.

#include <vector>

#include "imufusion/icp.hpp"
#include "imufusion/preprocess.hpp"
#include "imufusion/types.hpp"

namespace imufusion::reference {

/// One association result: the row a (6), b and weight w (0 = rejected); `valid` when the
/// current pixel has a vertex and a normal, and then z, the current vertex's depth, and
/// `covered` when its projection lands in front of the camera on a reference pixel with a vertex
/// and a normal.
struct IcpRow {
  Eigen::Matrix<double, 6, 1> a = Eigen::Matrix<double, 6, 1>::Zero();
  double b = 0;
  double w = 0;
  bool valid = false;
  bool covered = false;
  double z = 0;
};

std::vector<IcpRow> icp_associate(const Vec4Image& cur_vertices, const Vec4Image& cur_normals,
                                  const Vec4Image& ref_vertices, const Vec4Image& ref_normals,
                                  const Intrinsics& ref_intrinsics,
                                  const Eigen::Isometry3d& T_ref_cur, double max_distance,
                                  double min_normal_cos, const DepthNoiseModel& noise = {},
                                  const NormalGate& gate = {});

/// Sums of the accepted rows, and the noise information of the valid and of the paired pixels.
NormalEquations icp_reduce(const std::vector<IcpRow>& rows, const DepthNoiseModel& noise);

class CpuNormalEquationSource : public NormalEquationSource {
 public:
  CpuNormalEquationSource(PreprocessedFrame reference, PreprocessedFrame current,
                          const Intrinsics& intrinsics, const DepthNoiseModel& noise = {},
                          const NormalGate& gate = {});
  int levels() const override { return static_cast<int>(current_.vertices.size()); }
  Result<NormalEquations> evaluate(int level, const Eigen::Isometry3d& T_ref_cur,
                                   float max_distance, float min_normal_cos) override;

 private:
  PreprocessedFrame reference_, current_;
  Intrinsics intrinsics_;
  DepthNoiseModel noise_;
  NormalGate gate_;
};

}  // namespace imufusion::reference

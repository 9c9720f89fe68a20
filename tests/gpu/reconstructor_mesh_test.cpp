// The incremental mesh of a live scan (Reconstructor::extract_mesh_changes) on the synthetic room
// at known poses: the pieces a viewer holds add up to extract_mesh(), a frame fusing part of the
// view returns only the blocks near what it fused, and nothing fused returns nothing.

#include <map>
#include <tuple>

#include "../support/triangle_soup.hpp"
#include "mesh/lattice_key.hpp"
#include "reconstructor_test_support.hpp"

namespace imufusion {
namespace {

using test::ReconstructorTest;

// What a viewer holds: one piece per block, replaced or dropped by each update.
struct Viewer {
  std::map<std::tuple<int, int, int>, Mesh> pieces;

  void apply(MeshUpdate& update) {
    for (const Eigen::Vector3i& b : update.removed) {
      EXPECT_EQ(pieces.erase({b.x(), b.y(), b.z()}), 1u) << "removed a block never shown";
    }
    for (BlockMesh& piece : update.changed) {
      EXPECT_FALSE(piece.mesh.triangles.empty());
      pieces[{piece.block.x(), piece.block.y(), piece.block.z()}] = std::move(piece.mesh);
    }
  }

  std::vector<test::SoupTriangle> soup() const {
    std::vector<test::SoupTriangle> all;
    for (const auto& [block, mesh] : pieces) test::add_to_soup(mesh, all);
    return test::sorted_soup(std::move(all));
  }
};

class MeshChangesTest : public ReconstructorTest {
 protected:
  Result<FrameResult> fuse(Reconstructor& rec, std::size_t i, const DepthImage* depth = nullptr) {
    const Frame& f = frames_[i];
    const StampedPose* pose = find_pose(reader_->ground_truth(), f.timestamp);
    EXPECT_NE(pose, nullptr);
    const Eigen::Isometry3d T0 = reader_->ground_truth().front().T_world_camera;
    return rec.fuse_with_pose(f.timestamp, depth != nullptr ? *depth : f.depth,
                              f.color ? &*f.color : nullptr, T0.inverse() * pose->T_world_camera,
                              f.imu);
  }

  // Applies an update and checks that the viewer's pieces hold extract_mesh()'s triangles.
  void update_and_compare(Reconstructor& rec, Viewer& viewer, MeshUpdate* out = nullptr) {
    auto update = rec.extract_mesh_changes();
    ASSERT_TRUE(update.ok()) << update.error().describe();
    if (out != nullptr) *out = *update;
    viewer.apply(*update);
    auto whole = rec.extract_mesh();
    ASSERT_TRUE(whole.ok()) << whole.error().describe();
    ASSERT_GT(whole->triangles.size(), 0u);
    EXPECT_EQ(viewer.soup(), test::triangle_soup(*whole));
  }
};

TEST_F(MeshChangesTest, PiecesAddUpToTheWholeMeshAfterEachUpdate) {
  Reconstructor rec = make(config(true, 2));
  Viewer viewer;
  for (std::size_t i = 0; i < 16; ++i) {
    ASSERT_TRUE(fuse(rec, i).ok());
    if (i == 0 || i == 1 || i == 5 || i == 15) update_and_compare(rec, viewer);
  }
  EXPECT_GT(viewer.pieces.size(), 50u);
  // Nothing fused since: no changes.
  auto none = rec.extract_mesh_changes();
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->changed.empty());
  EXPECT_TRUE(none->removed.empty());
  // A frame without depth fuses nothing: still none.
  DepthImage blank = frames_[16].depth;
  std::fill(blank.data.begin(), blank.data.end(), 0);
  auto r = rec.track_and_fuse(frames_[16].timestamp, blank, nullptr, frames_[16].imu);
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r->fused);
  none = rec.extract_mesh_changes();
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->changed.empty());
  EXPECT_TRUE(none->removed.empty());
  EXPECT_EQ(rec.validation_error_count(), 0u);
}

// A frame whose depth is kept in a 24x24 pixel window only: the update holds the blocks near the
// surface it saw, a small part of the model.
TEST_F(MeshChangesTest, APartialFrameReturnsOnlyTheBlocksNearItsSurface) {
  Reconstructor rec = make(config(true, 2));
  Viewer viewer;
  for (std::size_t i = 0; i < 12; ++i) ASSERT_TRUE(fuse(rec, i).ok());
  update_and_compare(rec, viewer);
  const std::size_t total = viewer.pieces.size();

  const std::size_t i = 12;
  DepthImage window = frames_[i].depth;
  const int u0 = 68, v0 = 48, side = 24;
  for (int v = 0; v < window.height; ++v) {
    for (int u = 0; u < window.width; ++u) {
      if (u < u0 || u >= u0 + side || v < v0 || v >= v0 + side)
        window.data[static_cast<std::size_t>(v) * window.width + u] = 0;
    }
  }
  auto fused = fuse(rec, i, &window);
  ASSERT_TRUE(fused.ok()) << fused.error().describe();
  ASSERT_TRUE(fused->fused);
  MeshUpdate update;
  update_and_compare(rec, viewer, &update);
  const std::size_t returned = update.changed.size() + update.removed.size();
  EXPECT_GT(update.changed.size(), 0u);
  EXPECT_LT(returned * 4, total) << returned << " of " << total << " blocks";

  // Blocks the window's truncation bands pass through (points at the depth and a truncation
  // before and after it): every block returned lies within two blocks of one of them.
  const Intrinsics& k = rec.config().intrinsics;
  const double block = kBlockSide * rec.config().volume.voxel_size;
  const double band = rec.config().volume.truncation();
  std::vector<Eigen::Vector3i> seen;
  for (int v = v0; v < v0 + side; ++v) {
    for (int u = u0; u < u0 + side; ++u) {
      const double d = window.at(u, v) / window.depth_scale;
      if (d <= 0) continue;
      const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      for (double s : {d - band, d, d + band}) {
        const Eigen::Vector3d w = fused->T_world_camera * (ray * s);
        seen.push_back((w / block).array().floor().cast<int>().matrix());
      }
    }
  }
  ASSERT_FALSE(seen.empty());
  for (const BlockMesh& piece : update.changed) {
    int nearest = 1 << 20;
    for (const Eigen::Vector3i& b : seen)
      nearest = std::min(nearest, (b - piece.block).cwiseAbs().maxCoeff());
    EXPECT_LE(nearest, 2) << piece.block.transpose();
  }
}

TEST_F(MeshChangesTest, AfterResetTheOldPiecesAreRemoved) {
  Reconstructor rec = make(config(true, 2));
  Viewer viewer;
  for (std::size_t i = 0; i < 3; ++i) ASSERT_TRUE(fuse(rec, i).ok());
  auto first = rec.extract_mesh_changes();
  ASSERT_TRUE(first.ok());
  const std::size_t shown = first->changed.size();
  ASSERT_GT(shown, 0u);
  viewer.apply(*first);
  ASSERT_TRUE(rec.reset().ok());
  auto cleared = rec.extract_mesh_changes();
  ASSERT_TRUE(cleared.ok());
  EXPECT_TRUE(cleared->changed.empty());
  EXPECT_EQ(cleared->removed.size(), shown);
  viewer.apply(*cleared);
  EXPECT_TRUE(viewer.pieces.empty());
  // The next scan starts over: its pieces add up to its mesh.
  ASSERT_TRUE(fuse(rec, 20).ok());
  update_and_compare(rec, viewer);
}

}  // namespace
}  // namespace imufusion

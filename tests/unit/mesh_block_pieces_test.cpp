// extract_block_meshes: the mesh in pieces per block, as the incremental mesh
// (Reconstructor::extract_mesh_changes) hands them to a viewer.

#include <gtest/gtest.h>

#include <vector>

#include "../support/triangle_soup.hpp"
#include "imufusion/mesh.hpp"
#include "mesh_test_fixtures.hpp"

namespace imufusion {
namespace {

using test::make_sdf_volume;
using test::sphere_sdf;

HostVolume coloured_sphere() {
  auto color = [](const Eigen::Vector3d& p) {
    return std::array<std::uint8_t, 3>{static_cast<std::uint8_t>(128 + 300 * p.x()),
                                       static_cast<std::uint8_t>(128 + 300 * p.y()), 77};
  };
  return make_sdf_volume(sphere_sdf(Eigen::Vector3d(0.013, -0.027, 0.041), 0.3),
                         Eigen::Vector3i::Constant(-6), Eigen::Vector3i::Constant(6), 0.01f, 4.0f,
                         color);
}

std::vector<Eigen::Vector3i> coords(const HostVolume& volume) {
  std::vector<Eigen::Vector3i> out;
  for (const VolumeBlock& b : volume.blocks) out.push_back(b.coord);
  return out;
}

TEST(BlockMeshes, PiecesOfAllBlocksHoldTheWholeMesh) {
  const HostVolume volume = coloured_sphere();
  auto whole = extract_mesh(volume);
  ASSERT_TRUE(whole.ok()) << whole.error().describe();
  const std::vector<Eigen::Vector3i> blocks = coords(volume);
  auto pieces = extract_block_meshes(volume, blocks);
  ASSERT_TRUE(pieces.ok()) << pieces.error().describe();
  ASSERT_EQ(pieces->size(), blocks.size());
  std::vector<test::SoupTriangle> soup;
  std::size_t non_empty = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const BlockMesh& piece = (*pieces)[b];
    EXPECT_EQ(piece.block, blocks[b]);
    ASSERT_TRUE(check_mesh(piece.mesh).ok());
    non_empty += !piece.mesh.triangles.empty();
    // Each vertex lies on an edge of the block's cells: voxels 8 b .. 8 b + 8 on each axis.
    for (const Eigen::Vector3f& v : piece.mesh.vertices) {
      const Eigen::Vector3f lattice = v / volume.voxel_size;
      for (int axis = 0; axis < 3; ++axis) {
        EXPECT_GE(lattice[axis], static_cast<float>(8 * piece.block[axis]) - 1e-3f);
        EXPECT_LE(lattice[axis], static_cast<float>(8 * piece.block[axis] + 8) + 1e-3f);
      }
    }
    test::add_to_soup(piece.mesh, soup);
  }
  EXPECT_GT(non_empty, 50u);
  EXPECT_LT(non_empty, blocks.size());  // blocks inside the band hold no surface
  EXPECT_EQ(test::sorted_soup(std::move(soup)), test::triangle_soup(*whole));
}

// A piece reads only its block and the 26 around it.
TEST(BlockMeshes, APieceNeedsOnlyItsNeighbours) {
  const HostVolume volume = coloured_sphere();
  const std::vector<Eigen::Vector3i> blocks = coords(volume);
  auto all = extract_block_meshes(volume, blocks);
  ASSERT_TRUE(all.ok());
  std::size_t compared = 0;
  for (std::size_t b = 0; b < blocks.size(); b += 7) {
    HostVolume local;
    local.voxel_size = volume.voxel_size;
    local.truncation = volume.truncation;
    for (const VolumeBlock& block : volume.blocks) {
      if ((block.coord - blocks[b]).cwiseAbs().maxCoeff() <= 1) local.blocks.push_back(block);
    }
    const Eigen::Vector3i one = blocks[b];
    auto piece = extract_block_meshes(local, std::span(&one, 1));
    ASSERT_TRUE(piece.ok());
    EXPECT_EQ(test::triangle_soup(piece->front().mesh), test::triangle_soup((*all)[b].mesh));
    compared += !(*all)[b].mesh.triangles.empty();
  }
  EXPECT_GT(compared, 5u);
}

TEST(BlockMeshes, AbsentBlocksAreEmptyAndFarOnesErrors) {
  const HostVolume volume = coloured_sphere();
  const std::vector<Eigen::Vector3i> absent = {Eigen::Vector3i(40, 0, 0)};
  auto empty = extract_block_meshes(volume, absent);
  ASSERT_TRUE(empty.ok());
  ASSERT_EQ(empty->size(), 1u);
  EXPECT_EQ(empty->front().block, absent.front());
  EXPECT_TRUE(empty->front().mesh.triangles.empty());
  EXPECT_TRUE(empty->front().mesh.vertices.empty());

  const std::vector<Eigen::Vector3i> far = {Eigen::Vector3i(0, 1 << 16, 0)};
  auto error = extract_block_meshes(volume, far);
  ASSERT_FALSE(error.ok());
  EXPECT_EQ(error.error().code, ErrorCode::kInvalidArgument);
  MeshOptions bad;
  bad.min_weight = 0;
  EXPECT_FALSE(extract_block_meshes(volume, absent, bad).ok());
}

}  // namespace
}  // namespace imufusion

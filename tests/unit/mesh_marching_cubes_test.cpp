// Marching cubes on volumes written from analytic SDFs: geometry, topology, orientation, colour,
// block borders, unobserved voxels, determinism.

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

#include "imufusion/mesh.hpp"
#include "mesh/marching_cubes_tables.hpp"
#include "mesh_test_fixtures.hpp"

namespace imufusion {
namespace {

using test::count_edges;
using test::make_sdf_volume;
using test::sphere_sdf;

const Eigen::Vector3d kCentre(0.013, -0.027, 0.041);  // off the lattice on purpose
constexpr double kRadius = 0.3;                       // metres; voxels of 1 cm

HostVolume sphere_volume(const test::ColorFn& color = {}) {
  return make_sdf_volume(sphere_sdf(kCentre, kRadius), Eigen::Vector3i::Constant(-6),
                         Eigen::Vector3i::Constant(6), 0.01f, 4.0f, color);
}

std::set<std::array<int, 3>> sorted_triangles(int cube) {
  std::set<std::array<int, 3>> out;
  const auto& c = mesh::kTables.triangles[static_cast<std::size_t>(cube)];
  for (int t = 0; t < c.count; ++t) {
    std::array<int, 3> tri{c.edges[t][0], c.edges[t][1], c.edges[t][2]};
    std::sort(tri.begin(), tri.end());
    out.insert(tri);
  }
  return out;
}

TEST(MarchingCubesTables, MatchStandardEntriesAndUseExactlyTheCrossedEdges) {
  EXPECT_EQ(mesh::kTables.triangles[0].count, 0);
  EXPECT_EQ(mesh::kTables.triangles[255].count, 0);
  // Entries of the standard table (Bourke's triTable), as unordered triangles.
  EXPECT_EQ(sorted_triangles(1), (std::set<std::array<int, 3>>{{0, 3, 8}}));
  EXPECT_EQ(sorted_triangles(5), (std::set<std::array<int, 3>>{{0, 3, 8}, {1, 2, 10}}));
  EXPECT_EQ(mesh::kTables.edge_mask[1], 0x109);
  EXPECT_EQ(mesh::kTables.edge_mask[5], 0x50f);
  for (int cube = 0; cube < 256; ++cube) {
    std::uint16_t used = 0;
    const auto& c = mesh::kTables.triangles[static_cast<std::size_t>(cube)];
    std::map<std::pair<int, int>, int> directed;
    for (int t = 0; t < c.count; ++t) {
      for (int v = 0; v < 3; ++v) {
        used = static_cast<std::uint16_t>(used | (1u << c.edges[t][v]));
        ++directed[{c.edges[t][v], c.edges[t][(v + 1) % 3]}];
      }
    }
    EXPECT_EQ(used, mesh::kTables.edge_mask[static_cast<std::size_t>(cube)]) << "case " << cube;
    // Inside the cell, the fan's diagonals are shared by two triangles in opposite directions.
    for (const auto& [edge, count] : directed) {
      EXPECT_EQ(count, 1) << "case " << cube;
    }
  }
}

TEST(MarchingCubes, SphereVerticesLieOnTheSphereWithOutwardNormals) {
  auto mesh = extract_mesh(sphere_volume());
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  ASSERT_GT(mesh->vertices.size(), 1000u);
  ASSERT_EQ(mesh->normals.size(), mesh->vertices.size());
  EXPECT_TRUE(mesh->colors.empty() || mesh->colors.size() == mesh->vertices.size());
  ASSERT_TRUE(check_mesh(*mesh).ok());
  // Linear interpolation of exact SDF samples: the error is the SDF's curvature along a 1 cm
  // edge, h^2 / (8 R) ~ 4e-5 m. Bound: 1e-4 m, a hundredth of a voxel.
  double worst = 0.0, worst_normal = 1.0;
  for (std::size_t v = 0; v < mesh->vertices.size(); ++v) {
    const Eigen::Vector3d p = mesh->vertices[v].cast<double>() - kCentre;
    worst = std::max(worst, std::abs(p.norm() - kRadius));
    EXPECT_NEAR(mesh->normals[v].norm(), 1.0f, 1e-5f);
    worst_normal = std::min(worst_normal, mesh->normals[v].cast<double>().dot(p.normalized()));
  }
  EXPECT_LT(worst, 1e-4);
  EXPECT_GT(worst_normal, 0.999);  // outward, within ~2.5 degrees
  // Every triangle counter-clockwise seen from outside.
  for (const auto& tri : mesh->triangles) {
    const Eigen::Vector3d a = mesh->vertices[tri[0]].cast<double>();
    const Eigen::Vector3d b = mesh->vertices[tri[1]].cast<double>();
    const Eigen::Vector3d c = mesh->vertices[tri[2]].cast<double>();
    const Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-12) continue;
    ASSERT_GT(n.normalized().dot(((a + b + c) / 3.0 - kCentre).normalized()), 0.9);
  }
}

TEST(MarchingCubes, SphereIsWatertightWithEulerCharacteristicTwo) {
  auto mesh = extract_mesh(sphere_volume());
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  const auto edges = count_edges(*mesh);
  for (const auto& [edge, count] : edges.undirected) {
    ASSERT_EQ(count, 2) << "edge " << edge.first << "-" << edge.second;
  }
  for (const auto& [edge, count] : edges.directed) {
    ASSERT_EQ(count, 1) << "inconsistent orientation at edge " << edge.first << "-" << edge.second;
  }
  const auto v = static_cast<long>(mesh->vertices.size());
  const auto e = static_cast<long>(edges.undirected.size());
  const auto f = static_cast<long>(mesh->triangles.size());
  EXPECT_EQ(v - e + f, 2);
}

TEST(MarchingCubes, InterpolatesColours) {
  // Red ramps linearly along x (2 per voxel) so that the interpolated value is known exactly.
  auto color = [](const Eigen::Vector3d& p) {
    const long x = std::lround(p.x() / 0.01);
    return std::array<std::uint8_t, 3>{static_cast<std::uint8_t>(128 + 2 * x), 40, 200};
  };
  auto mesh = extract_mesh(sphere_volume(color));
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  ASSERT_EQ(mesh->colors.size(), mesh->vertices.size());
  for (std::size_t v = 0; v < mesh->vertices.size(); ++v) {
    const double expected = 128.0 + 2.0 * mesh->vertices[v].x() / 0.01;
    ASSERT_NEAR(mesh->colors[v][0], expected, 0.51);
    ASSERT_EQ(mesh->colors[v][1], 40);
    ASSERT_EQ(mesh->colors[v][2], 200);
  }
  MeshOptions no_colors;
  no_colors.colors = false;
  auto plain = extract_mesh(sphere_volume(color), no_colors);
  ASSERT_TRUE(plain.ok());
  EXPECT_TRUE(plain->colors.empty());
  EXPECT_EQ(plain->vertices.size(), mesh->vertices.size());
}

TEST(MarchingCubes, TiltedPlaneHasNoCracksAtBlockBorders) {
  const Eigen::Vector3d normal = Eigen::Vector3d(0.15, -0.1, 1.0).normalized();
  const auto sdf = [&](const Eigen::Vector3d& p) { return normal.dot(p) - 0.0437; };
  const HostVolume volume =
      make_sdf_volume(sdf, Eigen::Vector3i(-3, -3, -2), Eigen::Vector3i(2, 2, 2));
  auto mesh = extract_mesh(volume);
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  ASSERT_GT(mesh->triangles.size(), 1000u);
  // The mesh spans x, y in [-0.24, 0.23] m (the lattice of blocks -3 .. 2 minus the last cell):
  // only edges on that outer border may be open.
  const auto edges = count_edges(*mesh);
  int open = 0;
  for (const auto& [edge, count] : edges.undirected) {
    ASSERT_LE(count, 2);
    if (count == 2) continue;
    ++open;
    const Eigen::Vector3f mid = 0.5f * (mesh->vertices[edge.first] + mesh->vertices[edge.second]);
    const bool on_border =
        mid.x() < -0.235f || mid.x() > 0.225f || mid.y() < -0.235f || mid.y() > 0.225f;
    ASSERT_TRUE(on_border) << "open edge inside the volume at " << mid.transpose();
  }
  EXPECT_GT(open, 0);
  for (std::size_t v = 0; v < mesh->vertices.size(); ++v) {
    ASSERT_NEAR(sdf(mesh->vertices[v].cast<double>()), 0.0, 1e-5);
    ASSERT_GT(mesh->normals[v].cast<double>().dot(normal), 0.9999);
  }
}

TEST(MarchingCubes, UnobservedVoxelsAndMissingBlocksProduceNothing) {
  HostVolume volume = sphere_volume();
  // Unobserve every voxel with x > 0.05 m.
  for (auto& block : volume.blocks) {
    for (int k = 0; k < kBlockSide; ++k) {
      for (int j = 0; j < kBlockSide; ++j) {
        for (int i = 0; i < kBlockSide; ++i) {
          if ((kBlockSide * block.coord.x() + i) * 0.01 > 0.05) {
            block.voxels[voxel_index(i, j, k)].weight = 0.0f;
          }
        }
      }
    }
  }
  auto mesh = extract_mesh(volume);
  ASSERT_TRUE(mesh.ok());
  ASSERT_FALSE(mesh->triangles.empty());
  for (const auto& p : mesh->vertices) ASSERT_LE(p.x(), 0.05f + 1e-6f);

  // Dropping a block removes every cell with a corner in it.
  HostVolume holed = sphere_volume();
  const Eigen::Vector3i removed(-1, -1, 4);  // a block the sphere's top crosses
  const auto it = std::find_if(holed.blocks.begin(), holed.blocks.end(),
                               [&](const VolumeBlock& b) { return b.coord == removed; });
  ASSERT_NE(it, holed.blocks.end());
  holed.blocks.erase(it);
  auto with_hole = extract_mesh(holed);
  ASSERT_TRUE(with_hole.ok());
  for (const auto& p : with_hole->vertices) {
    const Eigen::Vector3d lattice = p.cast<double>() / 0.01;
    const bool inside =
        (lattice.array() > (removed * 8).cast<double>().array()).all() &&
        (lattice.array() < (removed * 8 + Eigen::Vector3i::Constant(8)).cast<double>().array())
            .all();
    ASSERT_FALSE(inside) << p.transpose();
  }
  EXPECT_LT(with_hole->triangles.size(), extract_mesh(sphere_volume())->triangles.size());

  // Weights below min_weight count as unobserved.
  MeshOptions strict;
  strict.min_weight = 2.0f;
  auto none = extract_mesh(sphere_volume(), strict);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->vertices.empty());
  EXPECT_TRUE(none->triangles.empty());
}

TEST(MarchingCubes, OutputDoesNotDependOnBlockOrderOrThreads) {
  HostVolume volume = sphere_volume();
  MeshOptions one;
  one.threads = 1;
  auto reference = extract_mesh(volume, one);
  ASSERT_TRUE(reference.ok());
  std::mt19937 rng(7);
  std::shuffle(volume.blocks.begin(), volume.blocks.end(), rng);
  MeshOptions three;
  three.threads = 3;
  auto shuffled = extract_mesh(volume, three);
  ASSERT_TRUE(shuffled.ok());
  EXPECT_EQ(shuffled->vertices, reference->vertices);
  EXPECT_EQ(shuffled->normals, reference->normals);
  EXPECT_EQ(shuffled->triangles, reference->triangles);
}

TEST(MarchingCubes, RejectsBadInput) {
  HostVolume volume = sphere_volume();
  volume.blocks.push_back(volume.blocks.front());
  auto duplicate = extract_mesh(volume);
  ASSERT_FALSE(duplicate.ok());
  EXPECT_EQ(duplicate.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(duplicate.error().message.find("twice"), std::string::npos);

  HostVolume zero = sphere_volume();
  zero.voxel_size = 0.0f;
  EXPECT_FALSE(extract_mesh(zero).ok());

  MeshOptions options;
  options.min_weight = 0.0f;
  EXPECT_FALSE(extract_mesh(sphere_volume(), options).ok());

  HostVolume far;
  VolumeBlock block;
  block.coord = Eigen::Vector3i(1 << 16, 0, 0);
  far.blocks.push_back(block);
  EXPECT_FALSE(extract_mesh(far).ok());

  auto empty = extract_mesh(HostVolume{});
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->triangles.empty());
}

}  // namespace
}  // namespace imufusion

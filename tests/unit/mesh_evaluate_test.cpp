// Mesh accuracy / completeness against analytic scenes, distances to primitives, observed
// surface samples.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "imufusion/mesh.hpp"
#include "imufusion/mesh_eval.hpp"
#include "imufusion/synth.hpp"
#include "mesh_test_fixtures.hpp"

namespace imufusion {
namespace {

const Eigen::Vector3d kCentre(0.013, -0.027, 0.041);
constexpr double kRadius = 0.3;

synth::Scene sphere_scene() {
  synth::Scene scene;
  synth::Sphere sphere;
  sphere.center = kCentre;
  sphere.radius = kRadius;
  scene.spheres.push_back(sphere);
  return scene;
}

Mesh sphere_mesh() {
  return extract_mesh(test::make_sdf_volume(test::sphere_sdf(kCentre, kRadius),
                                            Eigen::Vector3i::Constant(-6),
                                            Eigen::Vector3i::Constant(6)))
      .value();
}

// Evenly spread points on the sphere (a Fibonacci lattice).
std::vector<Eigen::Vector3d> sphere_points(int n) {
  std::vector<Eigen::Vector3d> points;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n;
    const double r = std::sqrt(1.0 - z * z);
    points.push_back(
        kCentre + kRadius * Eigen::Vector3d(r * std::cos(golden * i), r * std::sin(golden * i), z));
  }
  return points;
}

TEST(DistanceToSurface, ExactForEachPrimitive) {
  synth::Scene scene;
  EXPECT_TRUE(std::isinf(synth::distance_to_surface(scene, Eigen::Vector3d::Zero())));

  synth::Box box;
  box.center = Eigen::Vector3d(1, 1, 0.5);
  box.half_extents = Eigen::Vector3d(0.5, 0.25, 0.5);
  box.yaw = std::numbers::pi / 2;  // the 0.5 m half extent now lies along world y
  scene.boxes = {box};
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(1, 2, 0.5)), 0.5, 1e-12);
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(1.5, 1, 0.5)), 0.25, 1e-12);
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(1, 1, 0.6)), 0.25, 1e-12);
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(1.25 + 0.3, 1.5 + 0.4, 0.5)), 0.5,
              1e-12);  // outside a vertical edge: diagonal distance

  scene.boxes.clear();
  synth::Cylinder cylinder;
  cylinder.center_xy = Eigen::Vector2d(2, 0);
  cylinder.radius = 0.5;
  cylinder.z_min = 0.0;
  cylinder.z_max = 1.0;
  scene.cylinders = {cylinder};
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(3, 0, 0.5)), 0.5, 1e-12);
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(2, 0, 0.9)), 0.1, 1e-12);
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(2.8, 0, 1.4)), 0.5, 1e-12);

  scene.cylinders.clear();
  synth::Plane plane;
  plane.normal = Eigen::Vector3d(0, 1, 0);
  plane.offset = -1.0;
  scene.planes = {plane};
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(5, 0.5, 7)), 1.5, 1e-12);

  scene.planes.clear();
  scene.room = synth::RoomShell{};  // [0, 6] x [0, 5] x [0, 3]
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(3, 2.5, 1.0)), 1.0, 1e-12);
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(5.8, 2.5, 1.5)), 0.2, 1e-12);
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(6.3, 2.5, 1.5)), 0.3, 1e-12);

  synth::Sphere ball;  // radius 0.5 in the middle of the room, nearer than its walls
  ball.center = Eigen::Vector3d(3.0, 2.5, 1.5);
  scene.spheres = {ball};
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(3.2, 2.5, 1.5)), 0.3, 1e-12);
  EXPECT_NEAR(synth::distance_to_surface(scene, Eigen::Vector3d(3.0, 2.5, 2.2)), 0.2, 1e-12);
}

TEST(EvaluateMesh, MarchingCubesSphereIsAccurateAndComplete) {
  const Mesh mesh = sphere_mesh();
  auto result = evaluate_mesh(mesh, sphere_scene(), sphere_points(5000));
  ASSERT_TRUE(result.ok()) << result.error().describe();
  // Vertices within 1e-4 m, flat triangles between them sag by at most ~h^2 / (8 R) ~ 4e-5 m.
  EXPECT_LT(result->accuracy_mean, 1e-4);
  EXPECT_LT(result->accuracy_p90, 1.5e-4);
  EXPECT_LE(result->accuracy_median, result->accuracy_p90);
  EXPECT_DOUBLE_EQ(result->completeness, 1.0);
  EXPECT_EQ(result->reference_points, 5000u);
  // 4 pi r^2 = 1.13 m^2 at one sample per (5 mm)^2.
  EXPECT_NEAR(static_cast<double>(result->mesh_samples),
              4 * std::numbers::pi * kRadius * kRadius / 25e-6, 100.0);
}

TEST(EvaluateMesh, ShiftedSphereLosesAccuracyAndCompleteness) {
  Mesh mesh = sphere_mesh();
  const Eigen::Vector3f shift(0.03f, 0.0f, 0.0f);
  for (auto& v : mesh.vertices) v += shift;
  auto result = evaluate_mesh(mesh, sphere_scene(), sphere_points(5000));
  ASSERT_TRUE(result.ok());
  // A point at angle theta from the shift is ~ 3 cm |cos theta| from the other sphere: the mean
  // over the sphere is 1.5 cm, and |cos theta| < 2/3 (within 2 cm) on 2/3 of it.
  EXPECT_NEAR(result->accuracy_mean, 0.015, 0.001);
  EXPECT_NEAR(result->accuracy_p90, 0.027, 0.001);
  EXPECT_NEAR(result->completeness, 2.0 / 3.0, 0.02);

  MeshEvalOptions tight;
  tight.completeness_threshold = 0.01;  // |cos theta| < 1/3: a third of the sphere
  auto strict = evaluate_mesh(mesh, sphere_scene(), sphere_points(5000), tight);
  ASSERT_TRUE(strict.ok());
  EXPECT_LT(strict->completeness, 0.5);
  EXPECT_NEAR(strict->completeness, 1.0 / 3.0, 0.02);
}

TEST(EvaluateMesh, CompletenessCountsOnlyCoveredReferencePoints) {
  // Reference points on the whole sphere, mesh of the upper half only (z above the centre).
  Mesh mesh = sphere_mesh();
  std::vector<std::array<std::uint32_t, 3>> upper;
  for (const auto& tri : mesh.triangles) {
    if (mesh.vertices[tri[0]].z() > kCentre.z()) upper.push_back(tri);
  }
  mesh.triangles = upper;
  const auto points = sphere_points(4000);
  auto result = evaluate_mesh(mesh, sphere_scene(), points);
  ASSERT_TRUE(result.ok());
  // Kept triangles have a vertex above the equator and are smaller than a cell diagonal (1.73
  // cm): every point more than 1.73 cm above the equator is covered, and none more than
  // 1.73 + 2 cm below it.
  const auto fraction_above = [&](double dz) {
    const auto n = std::count_if(points.begin(), points.end(), [&](const Eigen::Vector3d& p) {
      return p.z() > kCentre.z() + dz;
    });
    return static_cast<double>(n) / static_cast<double>(points.size());
  };
  EXPECT_GE(result->completeness, fraction_above(0.0174));
  EXPECT_LE(result->completeness, fraction_above(-0.0374));
  EXPECT_GT(result->completeness, 0.5);
  EXPECT_LT(result->accuracy_mean, 1e-4);
}

TEST(EvaluateMesh, RejectsBadInput) {
  const Mesh mesh = sphere_mesh();
  EXPECT_FALSE(evaluate_mesh(mesh, sphere_scene(), {}).ok());
  MeshEvalOptions bad;
  bad.completeness_threshold = 0.0;
  EXPECT_FALSE(evaluate_mesh(mesh, sphere_scene(), sphere_points(10), bad).ok());
  Mesh broken = mesh;
  broken.normals.clear();
  EXPECT_FALSE(evaluate_mesh(broken, sphere_scene(), sphere_points(10)).ok());

  auto empty = evaluate_mesh(Mesh{}, sphere_scene(), sphere_points(10));
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(std::isnan(empty->accuracy_mean));
  EXPECT_EQ(empty->completeness, 0.0);
  EXPECT_EQ(empty->mesh_samples, 0u);
}

TEST(ObservedSurfacePoints, SeesOnlyWhatIsInRangeAndFacing) {
  synth::Scene scene;
  synth::Plane floor;  // z = 0
  scene.planes.push_back(floor);
  const Intrinsics intrinsics = synth::default_intrinsics(160, 120);

  // Looking straight down from 1 m: camera z (forward) = world -z.
  Eigen::Isometry3d down = Eigen::Isometry3d::Identity();
  down.linear() = Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  down.translation() = Eigen::Vector3d(0, 0, 1);
  const Trajectory one{{0.0, down}};
  SurfaceSampleOptions options;
  options.pixel_step = 4;
  options.cell_size = 0.001;
  const auto points = observed_surface_points(scene, one, intrinsics, options);
  EXPECT_EQ(points.size(), static_cast<std::size_t>((160 / 4) * (120 / 4)));
  for (const auto& p : points) EXPECT_NEAR(p.z(), 0.0, 1e-9);

  // The same view twice adds nothing (one point per cell); coarse cells thin the points out.
  EXPECT_EQ(observed_surface_points(scene, {{0.0, down}, {0.1, down}}, intrinsics, options).size(),
            points.size());
  options.cell_size = 0.1;
  EXPECT_LT(observed_surface_points(scene, one, intrinsics, options).size(), points.size() / 4);

  // Beyond the maximum depth: nothing.
  options.cell_size = 0.001;
  Eigen::Isometry3d high = down;
  high.translation().z() = 6.0;
  EXPECT_TRUE(observed_surface_points(scene, {{0.0, high}}, intrinsics, options).empty());

  // Grazing view (camera looking along the floor, slightly down): the incidence limit drops
  // most of it.
  Eigen::Isometry3d grazing = Eigen::Isometry3d::Identity();
  const Eigen::Matrix3d look_x = (Eigen::Matrix3d() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished();
  grazing.linear() = look_x * Eigen::AngleAxisd(-0.05, Eigen::Vector3d::UnitX()).toRotationMatrix();
  grazing.translation() = Eigen::Vector3d(0, 0, 0.3);
  options.max_depth = 100.0;
  const auto all = observed_surface_points(scene, {{0.0, grazing}}, intrinsics, options);
  options.max_incidence_deg = 60.0;
  const auto steep = observed_surface_points(scene, {{0.0, grazing}}, intrinsics, options);
  EXPECT_LT(steep.size(), all.size());
}

}  // namespace
}  // namespace imufusion

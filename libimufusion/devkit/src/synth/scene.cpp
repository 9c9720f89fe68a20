// Analytic scene primitives: the furnished room and exact ray intersection.

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "imufusion/synth.hpp"
#include "synth/random.hpp"
#include "synth/scene_internal.hpp"

namespace imufusion::synth {

namespace {

constexpr double kMinT = 1e-9;
constexpr double kInf = std::numeric_limits<double>::infinity();

Material solid(float r, float g, float b) {
  Material m;
  m.color = Eigen::Vector3f(r, g, b);
  m.color2 = m.color;
  return m;
}

Material checker(const Eigen::Vector3f& a, const Eigen::Vector3f& b, double size) {
  Material m;
  m.color = a;
  m.color2 = b;
  m.checker_size = size;
  return m;
}

Eigen::Vector3f albedo_at(const Material& m, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  if (m.checker_size <= 0.0) return m.color;
  // Lay the checker out in the two world axes most parallel to the surface.
  int drop = 0;
  n.cwiseAbs().maxCoeff(&drop);
  long parity = 0;
  for (int axis = 0; axis < 3; ++axis) {
    if (axis == drop) continue;
    parity += static_cast<long>(std::floor(p[axis] / m.checker_size));
  }
  return (parity & 1) != 0 ? m.color2 : m.color;
}

/// Smallest root of a t^2 + b t + c = 0 above kMinT that passes `accept`, or kInf.
template <typename Accept>
double smallest_root(double a, double b, double c, Accept accept) {
  const double disc = b * b - 4.0 * a * c;
  if (disc < 0.0 || a <= 0.0) return kInf;
  const double s = std::sqrt(disc);
  // Numerically stable pair of roots.
  const double q = -0.5 * (b + (b >= 0.0 ? s : -s));
  double t0 = q / a;
  double t1 = q != 0.0 ? c / q : t0;
  if (t0 > t1) std::swap(t0, t1);
  if (t0 > kMinT && accept(t0)) return t0;
  if (t1 > kMinT && accept(t1)) return t1;
  return kInf;
}

/// Slab test in a box's local frame: entry/exit parameters and the axes where they happen.
struct Slab {
  double t_near = -kInf, t_far = kInf;
  int near_axis = 0, far_axis = 0;
};

Slab slab(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& lo,
          const Eigen::Vector3d& hi) {
  Slab s;
  for (int axis = 0; axis < 3; ++axis) {
    if (d[axis] == 0.0) {
      if (o[axis] < lo[axis] || o[axis] > hi[axis]) {
        s.t_near = kInf;
        s.t_far = -kInf;
        return s;
      }
      continue;
    }
    double ta = (lo[axis] - o[axis]) / d[axis];
    double tb = (hi[axis] - o[axis]) / d[axis];
    if (ta > tb) std::swap(ta, tb);
    if (ta > s.t_near) {
      s.t_near = ta;
      s.near_axis = axis;
    }
    if (tb < s.t_far) {
      s.t_far = tb;
      s.far_axis = axis;
    }
  }
  return s;
}

Eigen::Vector3d axis_normal(int axis, double direction_component) {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  n[axis] = direction_component > 0.0 ? -1.0 : 1.0;  // against the ray
  return n;
}

/// A candidate hit before the albedo lookup.
struct Candidate {
  double t = kInf;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  const Material* material = nullptr;
  int primitive = -1;
};

void hit_room(const RoomShell& room, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
              Candidate& best) {
  const Slab s = slab(o, d, room.min, room.max);
  if (!(s.t_far > kMinT) || s.t_far >= best.t || s.t_near > s.t_far) return;
  // Seen from inside, the ray leaves through the far face; the normal points back inside.
  const int axis = s.far_axis;
  best.t = s.t_far;
  best.normal = axis_normal(axis, d[axis]);
  best.primitive = 0;
  if (axis == 2) {
    best.material = d[2] < 0.0 ? &room.floor : &room.ceiling;
  } else {
    best.material = &room.walls[2 * axis + (d[axis] > 0.0 ? 1 : 0)];
  }
}

/// Entry parameter of the bounding sphere, or kInf when the ray misses it.
double bound_entry(const Bound& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  const Eigen::Vector3d oc = o - b.center;
  const double a = d.squaredNorm();
  const double half_b = oc.dot(d);
  const double c = oc.squaredNorm() - b.radius * b.radius;
  if (c <= 0.0) return 0.0;  // origin inside the bound
  const double disc = half_b * half_b - a * c;
  if (disc < 0.0 || half_b > 0.0) return kInf;
  return (-half_b - std::sqrt(disc)) / a;
}

void hit_box(const Box& box, const Eigen::Matrix3d& R, int id, const Eigen::Vector3d& o,
             const Eigen::Vector3d& d, Candidate& best) {
  const Eigen::Vector3d lo_local = R.transpose() * (o - box.center);
  const Eigen::Vector3d d_local = R.transpose() * d;
  const Slab s = slab(lo_local, d_local, -box.half_extents, box.half_extents);
  if (s.t_near > s.t_far || !(s.t_far > kMinT)) return;
  const bool from_outside = s.t_near > kMinT;
  const double t = from_outside ? s.t_near : s.t_far;
  if (t >= best.t) return;
  const int axis = from_outside ? s.near_axis : s.far_axis;
  best.t = t;
  best.normal = R * axis_normal(axis, d_local[axis]);
  best.material = &box.material;
  best.primitive = id;
}

void hit_cylinder(const Cylinder& cyl, int id, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                  Candidate& best) {
  const double ox = o.x() - cyl.center_xy.x(), oy = o.y() - cyl.center_xy.y();
  const double r2 = cyl.radius * cyl.radius;
  double t_best = best.t;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  const double t_side =
      smallest_root(d.x() * d.x() + d.y() * d.y(), 2.0 * (ox * d.x() + oy * d.y()),
                    ox * ox + oy * oy - r2, [&](double t) {
                      const double z = o.z() + t * d.z();
                      return z >= cyl.z_min && z <= cyl.z_max;
                    });
  if (t_side < t_best) {
    t_best = t_side;
    normal = Eigen::Vector3d(ox + t_side * d.x(), oy + t_side * d.y(), 0.0) / cyl.radius;
    if (normal.dot(d) > 0.0) normal = -normal;  // seen from inside
  }
  if (d.z() != 0.0) {
    for (const double zc : {cyl.z_min, cyl.z_max}) {
      const double t = (zc - o.z()) / d.z();
      if (!(t > kMinT) || t >= t_best) continue;
      const double x = ox + t * d.x(), y = oy + t * d.y();
      if (x * x + y * y > r2) continue;
      t_best = t;
      normal = axis_normal(2, d.z());
    }
  }
  if (t_best < best.t) {
    best.t = t_best;
    best.normal = normal;
    best.material = &cyl.material;
    best.primitive = id;
  }
}

void hit_sphere(const Sphere& sph, int id, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                Candidate& best) {
  const Eigen::Vector3d oc = o - sph.center;
  const double t =
      smallest_root(d.squaredNorm(), 2.0 * oc.dot(d), oc.squaredNorm() - sph.radius * sph.radius,
                    [](double) { return true; });
  if (t >= best.t) return;
  Eigen::Vector3d n = (oc + t * d) / sph.radius;
  if (n.dot(d) > 0.0) n = -n;
  best.t = t;
  best.normal = n;
  best.material = &sph.material;
  best.primitive = id;
}

void hit_plane(const Plane& plane, int id, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
               Candidate& best) {
  const double denom = plane.normal.dot(d);
  if (denom == 0.0) return;
  const double t = (plane.offset - plane.normal.dot(o)) / denom;
  if (!(t > kMinT) || t >= best.t) return;
  best.t = t;
  best.normal = denom > 0.0 ? Eigen::Vector3d(-plane.normal) : plane.normal;
  best.material = &plane.material;
  best.primitive = id;
}

}  // namespace

const char* to_string(SceneKind kind) {
  switch (kind) {
    case SceneKind::kRoom:
      return "room";
    case SceneKind::kWall:
      return "wall";
    case SceneKind::kFast:
      return "fast";
  }
  return "room";
}

std::optional<SceneKind> parse_scene_kind(std::string_view name) {
  if (name == "room") return SceneKind::kRoom;
  if (name == "wall") return SceneKind::kWall;
  if (name == "fast") return SceneKind::kFast;
  return std::nullopt;
}

Scene make_scene(SceneKind /*kind*/, std::uint64_t seed) {
  // Colours vary a little with the seed so that different seeds give different images even for
  // one pose; the geometry is fixed (the trajectories are designed around it).
  Rng rng(mix_seed(seed, 101));
  auto tint = [&rng](float r, float g, float b) {
    const auto jitter = [&rng]() { return static_cast<float>(rng.uniform(-0.06, 0.06)); };
    return solid(std::clamp(r + jitter(), 0.0f, 1.0f), std::clamp(g + jitter(), 0.0f, 1.0f),
                 std::clamp(b + jitter(), 0.0f, 1.0f));
  };

  Scene scene;
  RoomShell room;
  room.floor =
      checker(Eigen::Vector3f(0.75f, 0.72f, 0.65f), Eigen::Vector3f(0.35f, 0.30f, 0.25f), 0.5);
  room.ceiling = tint(0.92f, 0.92f, 0.90f);
  room.walls[0] = tint(0.80f, 0.75f, 0.62f);
  room.walls[1] = tint(0.70f, 0.78f, 0.82f);  // x = 6: the bare wall of the wall scene
  room.walls[2] = tint(0.82f, 0.70f, 0.70f);
  room.walls[3] = tint(0.72f, 0.80f, 0.70f);
  scene.room = room;

  auto box = [&scene](Eigen::Vector3d c, Eigen::Vector3d h, double yaw_deg, Material m) {
    scene.boxes.push_back(Box{c, h, yaw_deg * std::numbers::pi / 180.0, m});
  };
  auto cylinder = [&scene](double x, double y, double r, double z0, double z1, Material m) {
    scene.cylinders.push_back(Cylinder{Eigen::Vector2d(x, y), r, z0, z1, m});
  };
  auto sphere = [&scene](Eigen::Vector3d c, double r, Material m) {
    scene.spheres.push_back(Sphere{c, r, m});
  };
  using V = Eigen::Vector3d;

  // Central group (inside the camera orbit around (3, 2.5)): table, things on it, a lamp.
  box(V(3.0, 2.5, 0.375), V(0.6, 0.4, 0.375), 10.0, tint(0.55f, 0.35f, 0.20f));
  box(V(2.8, 2.4, 0.90), V(0.15, 0.20, 0.15), 30.0, tint(0.20f, 0.45f, 0.80f));
  sphere(V(3.35, 2.65, 0.87), 0.12, tint(0.85f, 0.20f, 0.20f));
  cylinder(3.15, 2.25, 0.07, 0.75, 1.05, tint(0.25f, 0.70f, 0.30f));
  cylinder(2.2, 2.9, 0.12, 0.0, 1.6, tint(0.30f, 0.30f, 0.35f));
  sphere(V(2.2, 2.9, 1.72), 0.16, tint(0.95f, 0.90f, 0.60f));
  box(V(3.9, 2.8, 0.5), V(0.2, 0.25, 0.5), -15.0,
      checker(Eigen::Vector3f(0.9f, 0.9f, 0.9f), Eigen::Vector3f(0.3f, 0.5f, 0.3f), 0.2));
  sphere(V(2.35, 2.0, 0.25), 0.25, tint(0.90f, 0.60f, 0.10f));
  box(V(3.6, 2.05, 0.2), V(0.25, 0.18, 0.2), 40.0, tint(0.60f, 0.25f, 0.60f));

  // Along the walls (outside the orbit), at several heights.
  box(V(1.5, 0.25, 0.9), V(0.6, 0.25, 0.9), 0.0, tint(0.45f, 0.30f, 0.20f));   // shelf
  box(V(1.3, 0.3, 1.95), V(0.2, 0.15, 0.15), 5.0, tint(0.20f, 0.60f, 0.70f));  // on shelf
  box(V(0.35, 4.6, 0.4), V(0.35, 0.4, 0.4), 0.0, tint(0.50f, 0.50f, 0.55f));   // corner
  cylinder(0.35, 2.0, 0.25, 0.0, 1.1, tint(0.60f, 0.40f, 0.30f));              // pot
  sphere(V(0.35, 2.0, 1.35), 0.22, tint(0.20f, 0.60f, 0.25f));                 // plant
  box(V(0.03, 3.3, 1.6), V(0.03, 0.45, 0.3), 0.0, tint(0.30f, 0.30f, 0.60f));  // picture
  box(V(3.5, 4.75, 0.6), V(0.8, 0.25, 0.6), 0.0, tint(0.40f, 0.25f, 0.15f));   // sideboard
  sphere(V(3.1, 4.75, 1.32), 0.12, tint(0.85f, 0.85f, 0.85f));
  cylinder(3.9, 4.7, 0.08, 1.2, 1.55, tint(0.80f, 0.30f, 0.50f));
  box(V(2.0, 4.97, 1.8), V(0.4, 0.03, 0.3), 0.0, tint(0.70f, 0.50f, 0.20f));  // picture
  box(V(5.6, 0.4, 0.5), V(0.4, 0.4, 0.5), 0.0, tint(0.35f, 0.45f, 0.35f));    // cabinet
  sphere(V(5.6, 0.4, 1.15), 0.15, tint(0.30f, 0.30f, 0.80f));
  cylinder(5.6, 4.6, 0.2, 0.0, 1.8, tint(0.55f, 0.55f, 0.50f));                // column
  box(V(5.0, 4.85, 2.2), V(0.5, 0.15, 0.05), 0.0, tint(0.50f, 0.35f, 0.25f));  // wall shelf
  return scene;
}

PreparedScene prepare(const Scene& scene) {
  PreparedScene prepared;
  prepared.scene = &scene;
  for (const Box& b : scene.boxes) {
    prepared.box_bounds.push_back({b.center, b.half_extents.norm()});
    prepared.box_rotations.push_back(
        Eigen::AngleAxisd(b.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix());
  }
  for (const Cylinder& c : scene.cylinders) {
    const double half_h = 0.5 * (c.z_max - c.z_min);
    prepared.cylinder_bounds.push_back(
        {Eigen::Vector3d(c.center_xy.x(), c.center_xy.y(), 0.5 * (c.z_min + c.z_max)),
         std::sqrt(half_h * half_h + c.radius * c.radius)});
  }
  return prepared;
}

std::optional<RayHit> intersect(const PreparedScene& prepared, const Eigen::Vector3d& o,
                                const Eigen::Vector3d& d) {
  const Scene& scene = *prepared.scene;
  Candidate best;
  // The room first: its hit bounds the search, so bounding spheres behind it are skipped.
  if (scene.room) hit_room(*scene.room, o, d, best);
  int id = 1;
  for (std::size_t i = 0; i < scene.boxes.size(); ++i, ++id) {
    if (bound_entry(prepared.box_bounds[i], o, d) < best.t) {
      hit_box(scene.boxes[i], prepared.box_rotations[i], id, o, d, best);
    }
  }
  for (std::size_t i = 0; i < scene.cylinders.size(); ++i, ++id) {
    if (bound_entry(prepared.cylinder_bounds[i], o, d) < best.t) {
      hit_cylinder(scene.cylinders[i], id, o, d, best);
    }
  }
  for (std::size_t i = 0; i < scene.spheres.size(); ++i, ++id) {
    hit_sphere(scene.spheres[i], id, o, d, best);
  }
  for (std::size_t i = 0; i < scene.planes.size(); ++i, ++id) {
    hit_plane(scene.planes[i], id, o, d, best);
  }
  if (best.material == nullptr) return std::nullopt;
  RayHit hit;
  hit.t = best.t;
  hit.point = o + best.t * d;
  hit.normal = best.normal;
  hit.albedo = albedo_at(*best.material, hit.point, hit.normal);
  hit.primitive = best.primitive;
  return hit;
}

std::optional<RayHit> intersect(const Scene& scene, const Eigen::Vector3d& origin,
                                const Eigen::Vector3d& direction) {
  return intersect(prepare(scene), origin, direction);
}

}  // namespace imufusion::synth

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>

#include "imufusion/mesh.hpp"
#include "mesh/mesh_internal.hpp"

namespace imufusion {
namespace mesh {

void compute_vertex_normals(Mesh& mesh) {
  // In double: with coordinates near float's limit (3.4e38) the cross product overflows float.
  std::vector<Eigen::Vector3d> sum(mesh.vertices.size(), Eigen::Vector3d::Zero());
  for (const auto& tri : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[tri[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[tri[2]].cast<double>();
    const Eigen::Vector3d area_normal = (b - a).cross(c - a);  // length: twice the area
    for (std::uint32_t v : tri) sum[v] += area_normal;
  }
  mesh.normals.resize(mesh.vertices.size());
  for (std::size_t v = 0; v < sum.size(); ++v) {
    const double length = sum[v].norm();
    mesh.normals[v] =
        length > 0.0 ? Eigen::Vector3f((sum[v] / length).cast<float>()) : Eigen::Vector3f::UnitZ();
  }
}

Status check_mesh_for(const Mesh& mesh, const std::string& what) {
  const std::size_t n = mesh.vertices.size();
  auto fail = [&](const std::string& message) {
    return make_error(ErrorCode::kInvalidArgument, what + ": " + message);
  };
  if (mesh.normals.size() != n) {
    return fail(std::to_string(mesh.normals.size()) + " normals for " + std::to_string(n) +
                " vertices");
  }
  if (!mesh.colors.empty() && mesh.colors.size() != n) {
    return fail(std::to_string(mesh.colors.size()) + " colours for " + std::to_string(n) +
                " vertices");
  }
  if (n > 0xFFFFFFFFull) return fail(std::to_string(n) + " vertices exceed 32-bit indices");
  for (std::size_t v = 0; v < n; ++v) {
    if (!mesh.vertices[v].allFinite() || !mesh.normals[v].allFinite()) {
      return fail("vertex " + std::to_string(v) + " has a non-finite position or normal");
    }
  }
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (std::uint32_t v : mesh.triangles[t]) {
      if (v >= n) {
        return fail("triangle " + std::to_string(t) + " uses vertex " + std::to_string(v) + " of " +
                    std::to_string(n));
      }
    }
  }
  return {};
}

}  // namespace mesh

Status check_mesh(const Mesh& mesh) { return mesh::check_mesh_for(mesh, "mesh"); }

Result<Mesh> read_mesh(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".ply") return read_ply(path);
  if (extension == ".glb" || extension == ".gltf") return read_gltf(path);
  return make_error(ErrorCode::kUnsupported, path.string() + ": unknown mesh extension '" +
                                                 extension + "' (expected .ply, .glb or .gltf)");
}

}  // namespace imufusion

#pragma once
// Helpers shared by the mesh readers and writers.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "imufusion/mesh.hpp"

namespace imufusion::mesh {

/// Area-weighted vertex normals from the triangles (unit; +z for a vertex on no triangle with
/// area). Replaces mesh.normals.
void compute_vertex_normals(Mesh& mesh);

/// check_mesh() with the operation and file named in the message.
Status check_mesh_for(const Mesh& mesh, const std::string& what);

/// read_ply() on a file's bytes held in memory; `name` (the file) is only used in messages.
Result<Mesh> parse_ply(const std::vector<std::uint8_t>& bytes, const std::string& name);

/// read_gltf() on a file's bytes held in memory: a binary .glb when `binary`, else glTF JSON.
/// External buffers are looked up in `base_directory`; `name` (the file) is used in messages.
Result<Mesh> parse_gltf(const std::vector<std::uint8_t>& bytes, bool binary,
                        const std::filesystem::path& base_directory, const std::string& name);

}  // namespace imufusion::mesh

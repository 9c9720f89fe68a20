#pragma once
// Helpers shared by the mesh readers and writers.

#include <string>

#include "imufusion/mesh.hpp"

namespace imufusion::mesh {

/// Area-weighted vertex normals from the triangles (unit; +z for a vertex on no triangle with
/// area). Replaces mesh.normals.
void compute_vertex_normals(Mesh& mesh);

/// check_mesh() with the operation and file named in the message.
Status check_mesh_for(const Mesh& mesh, const std::string& what);

}  // namespace imufusion::mesh

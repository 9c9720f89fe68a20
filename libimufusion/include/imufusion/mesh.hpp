#pragma once
// Triangle meshes extracted from the volume, and their export. World frame, metres.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"
#include "imufusion/volume.hpp"

namespace imufusion {

struct Mesh {
  std::vector<Eigen::Vector3f> vertices;                // metres, world frame
  std::vector<Eigen::Vector3f> normals;                 // unit, one per vertex
  std::vector<std::array<std::uint8_t, 3>> colors;      // RGB per vertex (empty: no colour)
  std::vector<std::array<std::uint32_t, 3>> triangles;  // counter-clockwise seen from outside
};

/// Checks that a mesh is well formed: one normal per vertex, colours absent or one per vertex,
/// finite positions and normals, every index below the vertex count. kInvalidArgument otherwise.
Status check_mesh(const Mesh& mesh);

struct MeshOptions {
  /// A cell (8 neighbouring voxels) is meshed only when every corner has at least this weight
  /// (observations); 1 skips cells with any unobserved corner. Must be > 0.
  float min_weight = 1.0f;
  bool colors = true;  // interpolate voxel colours into Mesh::colors
  int threads = 0;     // worker threads over blocks; 0: std::thread::hardware_concurrency()
};

/// Marching cubes (Lorensen-Cline) over the snapshot's lattice. One vertex per crossed lattice
/// edge, shared by every triangle that uses it, so the mesh is closed where the surface is;
/// positions at the linear zero crossing of the TSDF, normals from the trilinear-consistent
/// central-difference TSDF gradient (pointing to positive TSDF, i.e. out of objects),
/// triangles counter-clockwise seen from the positive side. Cells spanning block borders use
/// the neighbour blocks; a cell with a missing block or an under-weighted corner yields nothing.
/// Faces with two diagonal negative corners keep the negative corners apart (the standard
/// table's choice). Output does not depend on the block order or the thread count.
/// kInvalidArgument for duplicate block coordinates, a non-positive voxel size or min_weight,
/// or a block coordinate beyond +-2^15.
Result<Mesh> extract_mesh(const HostVolume& volume, const MeshOptions& options = {});

/// One block's piece of the mesh: the triangles of the cells whose lower corner lies in the block
/// (voxels 8 b .. 8 b + 7 on each axis), with vertices of its own (not welded to its neighbours').
struct BlockMesh {
  Eigen::Vector3i block = Eigen::Vector3i::Zero();  // block coordinate (volume.hpp)
  Mesh mesh;
};

/// The pieces of the mesh that changed since the previous update: a viewer replaces the pieces of
/// the `changed` blocks and drops those of the `removed` ones.
struct MeshUpdate {
  std::vector<BlockMesh> changed;        // non-empty pieces, in (z, y, x) block order
  std::vector<Eigen::Vector3i> removed;  // blocks whose piece became empty, in (z, y, x) order
};

/// extract_mesh() of the listed blocks only: one piece per listed block, in the order given
/// (empty for a block that is not in the volume or holds no surface). A block's cells read its 26
/// neighbours' voxels, so `volume` must hold those that are allocated. Together, the pieces of all
/// the volume's blocks hold the triangles of extract_mesh(), with the same vertex positions,
/// normals and colours. Errors as extract_mesh(), and for a listed block beyond +-2^15.
Result<std::vector<BlockMesh>> extract_block_meshes(const HostVolume& volume,
                                                    std::span<const Eigen::Vector3i> blocks,
                                                    const MeshOptions& options = {});

/// Binary little-endian PLY: vertex x y z nx ny nz (float) [red green blue (uchar) when the mesh
/// has colours], face vertex_indices (list uchar uint). Written atomically (a temporary file in
/// the same directory renamed over `path`): an existing file is replaced whole or left as it
/// was. An empty mesh gives a valid PLY with zero vertices and faces.
Status write_ply(const std::filesystem::path& path, const Mesh& mesh);

/// Binary glTF 2.0: one mesh, one triangle primitive with POSITION (with min/max), NORMAL,
/// COLOR_0 (normalized unsigned byte RGB, when present) and uint32 indices, a matte material,
/// asset.generator "imufusion". Written atomically like write_ply(). An empty mesh (no
/// triangles) is refused with kInvalidArgument: glTF accessors cannot be empty.
Status write_glb(const std::filesystem::path& path, const Mesh& mesh);

/// Reads a PLY (binary little-endian; any property order, float or double coordinates, optional
/// normals and uchar colours, polygon faces fan-triangulated). Missing normals are computed from
/// the faces (area-weighted).
Result<Mesh> read_ply(const std::filesystem::path& path);

/// Reads a .glb or .gltf: every triangle primitive of every mesh, concatenated, node transforms
/// ignored (write_glb() writes none). Missing normals are computed from the faces.
Result<Mesh> read_gltf(const std::filesystem::path& path);

/// read_ply() or read_gltf() by extension (.ply, .glb, .gltf; case-insensitive).
Result<Mesh> read_mesh(const std::filesystem::path& path);

}  // namespace imufusion

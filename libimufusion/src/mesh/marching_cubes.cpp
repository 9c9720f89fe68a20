// Marching cubes over a HostVolume. Blocks are meshed independently (in parallel), each from an
// 11^3 gather of its voxels plus one layer of every neighbour (the +1 layer closes the cells on
// the block's far faces, the -1 and +2 layers feed the central differences of the normals);
// the per-block meshes are then welded in block-coordinate order, keyed by lattice edge.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <thread>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

#include "imufusion/mesh.hpp"
#include "mesh/lattice_key.hpp"
#include "mesh/marching_cubes_tables.hpp"

namespace imufusion {
namespace {

using mesh::kTables;

// Local lattice coordinates -1 .. kBlockSide + 1 around a block (origin at index 1).
constexpr int kGather = kBlockSide + 3;
constexpr int kGatherVoxels = kGather * kGather * kGather;

struct LocalVoxel {
  float tsdf = 0.0f;
  std::array<std::uint8_t, 3> color{};
  bool usable = false;  // present in the snapshot with weight >= min_weight
};

constexpr int gather_index(int x, int y, int z) {
  return (x + 1) + kGather * ((y + 1) + kGather * (z + 1));
}

// Edge keys use bits 0-61 (mesh::edge_key); bit 63 marks edges other blocks may share.
constexpr std::uint64_t kSharedBit = std::uint64_t{1} << 63;

// Edge key -> welded vertex index: open addressing with linear probing, several times faster
// than std::unordered_map for the millions of lookups of a large mesh.
class EdgeVertexMap {
 public:
  explicit EdgeVertexMap(std::size_t expected) {
    std::size_t capacity = 16;
    int bits = 4;
    while (capacity < 2 * expected) {
      capacity *= 2;
      ++bits;
    }
    mask_ = capacity - 1;
    shift_ = 64 - bits;
    keys_.assign(capacity, kEmpty);
    values_.resize(capacity);
  }

  // The value stored for `key`, storing `value` first when the key is new.
  std::uint32_t find_or_insert(std::uint64_t key, std::uint32_t value) {
    // Fibonacci hashing: the top bits of the product mix every bit of the key.
    std::size_t i = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
    for (;; i = (i + 1) & mask_) {
      if (keys_[i] == key) return values_[i];
      if (keys_[i] == kEmpty) {
        keys_[i] = key;
        values_[i] = value;
        return value;
      }
    }
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // not a valid edge key
  std::size_t mask_ = 0;
  int shift_ = 60;
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> values_;
};

struct BlockPart {
  // Per vertex: its lattice edge, with kSharedBit set when cells of other blocks may use the
  // edge too (its lower end lies on the block's lower faces or in the next block).
  std::vector<std::uint64_t> edge_keys;
  std::vector<Eigen::Vector3f> vertices, normals;
  std::vector<std::array<std::uint8_t, 3>> colors;
  std::vector<std::array<std::uint32_t, 3>> triangles;  // local vertex indices
};

using BlockIndex = std::unordered_map<std::uint64_t, std::size_t>;  // block key -> position

class Mesher {
 public:
  Mesher(const HostVolume& volume, const MeshOptions& options, const BlockIndex& index)
      : volume_(volume), options_(options), index_(index) {}

  void mesh_block(const VolumeBlock& block, BlockPart& out) {
    find_neighbours(block);
    // Cell corners first: most blocks hold no zero crossing (they lie within the truncation band
    // on one side of the surface), and those need neither the cells nor the outer layers.
    if (!gather(0, kBlockSide, false)) return;
    gather(-1, kBlockSide + 1, true);
    std::fill(edge_vertex_.begin(), edge_vertex_.end(), -1);
    const Eigen::Vector3i origin = block.coord * kBlockSide;
    for (int k = 0; k < kBlockSide; ++k) {
      for (int j = 0; j < kBlockSide; ++j) {
        for (int i = 0; i < kBlockSide; ++i) mesh_cell(origin, i, j, k, out);
      }
    }
  }

 private:
  void find_neighbours(const VolumeBlock& block) {
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const auto it = index_.find(mesh::block_key(block.coord + Eigen::Vector3i(dx, dy, dz)));
          neighbours_[(dx + 1) + 3 * ((dy + 1) + 3 * (dz + 1))] =
              it == index_.end() ? nullptr : &volume_.blocks[it->second];
        }
      }
    }
  }

  // Copies the local coordinates lo .. hi (on every axis) from the blocks; with `skip_inner` the
  // cell corners 0 .. kBlockSide, gathered before, are left as they are. Returns whether the
  // usable voxels copied include both signs.
  bool gather(int lo, int hi, bool skip_inner) {
    // Block offset and voxel index of a local coordinate in -1 .. kBlockSide + 1.
    auto split = [](int c, int& offset, int& voxel) {
      offset = c < 0 ? -1 : (c >= kBlockSide ? 1 : 0);
      voxel = c - offset * kBlockSide;
    };
    auto inner = [](int c) { return c >= 0 && c <= kBlockSide; };
    bool negative = false, positive = false;
    for (int z = lo; z <= hi; ++z) {
      int oz = 0, vz = 0;
      split(z, oz, vz);
      for (int y = lo; y <= hi; ++y) {
        int oy = 0, vy = 0;
        split(y, oy, vy);
        for (int x = lo; x <= hi; ++x) {
          if (skip_inner && inner(x) && inner(y) && inner(z)) continue;
          int ox = 0, vx = 0;
          split(x, ox, vx);
          LocalVoxel& local = local_[gather_index(x, y, z)];
          const VolumeBlock* source = neighbours_[(ox + 1) + 3 * ((oy + 1) + 3 * (oz + 1))];
          if (source == nullptr) {
            local.usable = false;
            continue;
          }
          const Voxel& voxel = source->voxels[voxel_index(vx, vy, vz)];
          local.usable = voxel.weight >= options_.min_weight && std::isfinite(voxel.tsdf);
          local.tsdf = voxel.tsdf;
          local.color = voxel.color;
          if (local.usable) (voxel.tsdf < 0.0f ? negative : positive) = true;
        }
      }
    }
    return negative && positive;
  }

  const LocalVoxel& at(int x, int y, int z) const { return local_[gather_index(x, y, z)]; }

  // TSDF gradient at a lattice point (local coordinates): central differences where both
  // neighbours are usable, one-sided otherwise (the point is a usable cell corner, so along each
  // axis at least the cell's own neighbour is usable).
  Eigen::Vector3f gradient(int x, int y, int z) const {
    const float centre = at(x, y, z).tsdf;
    Eigen::Vector3f g;
    for (int axis = 0; axis < 3; ++axis) {
      const int dx = axis == 0, dy = axis == 1, dz = axis == 2;
      const LocalVoxel& plus = at(x + dx, y + dy, z + dz);
      const LocalVoxel& minus = at(x - dx, y - dy, z - dz);
      if (plus.usable && minus.usable) {
        g[axis] = 0.5f * (plus.tsdf - minus.tsdf);
      } else if (plus.usable) {
        g[axis] = plus.tsdf - centre;
      } else if (minus.usable) {
        g[axis] = centre - minus.tsdf;
      } else {
        g[axis] = 0.0f;
      }
    }
    return g;
  }

  void mesh_cell(const Eigen::Vector3i& origin, int i, int j, int k, BlockPart& out) {
    int cube = 0;
    for (int c = 0; c < 8; ++c) {
      const auto& corner = mesh::kCorner[c];
      const LocalVoxel& v = at(i + corner[0], j + corner[1], k + corner[2]);
      if (!v.usable) return;
      if (v.tsdf < 0.0f) cube |= 1 << c;
    }
    const mesh::CaseTriangles& triangles = kTables.triangles[cube];
    if (triangles.count == 0) return;
    for (int t = 0; t < triangles.count; ++t) {
      std::array<std::uint32_t, 3> tri{};
      for (int v = 0; v < 3; ++v) tri[v] = edge_vertex(origin, i, j, k, triangles.edges[t][v], out);
      out.triangles.push_back(tri);
    }
  }

  // The vertex on edge `e` of cell (i, j, k), created on first use. Computed from the edge's
  // lower end toward its upper end, so every block that meets the edge computes the same bits.
  std::uint32_t edge_vertex(const Eigen::Vector3i& origin, int i, int j, int k, int e,
                            BlockPart& out) {
    const auto& c0 = mesh::kCorner[mesh::kEdgeCorners[e][0]];
    const auto& c1 = mesh::kCorner[mesh::kEdgeCorners[e][1]];
    int axis = 0;
    while (c0[axis] == c1[axis]) ++axis;
    const auto& lo = c0[axis] < c1[axis] ? c0 : c1;
    const int x = i + lo[0], y = j + lo[1], z = k + lo[2];
    int& slot = edge_vertex_[static_cast<std::size_t>(
        axis + 3 * (x + (kBlockSide + 1) * (y + (kBlockSide + 1) * z)))];
    if (slot >= 0) return static_cast<std::uint32_t>(slot);

    const int dx = axis == 0, dy = axis == 1, dz = axis == 2;
    const LocalVoxel& a = at(x, y, z);
    const LocalVoxel& b = at(x + dx, y + dy, z + dz);
    const float t = a.tsdf / (a.tsdf - b.tsdf);  // in [0, 1]: the case says the signs differ
    Eigen::Vector3d lattice(origin.x() + x, origin.y() + y, origin.z() + z);
    lattice[axis] += static_cast<double>(t);
    Eigen::Vector3f normal = (1.0f - t) * gradient(x, y, z) + t * gradient(x + dx, y + dy, z + dz);
    if (normal.norm() > 0.0f) {
      normal.normalize();
    } else {
      normal = Eigen::Vector3f::Zero();
      normal[axis] = b.tsdf > a.tsdf ? 1.0f : -1.0f;
    }

    slot = static_cast<int>(out.vertices.size());
    const bool shared =
        x == 0 || y == 0 || z == 0 || x == kBlockSide || y == kBlockSide || z == kBlockSide;
    out.edge_keys.push_back(
        mesh::edge_key(Eigen::Vector3i(origin.x() + x, origin.y() + y, origin.z() + z), axis) |
        (shared ? kSharedBit : 0));
    out.vertices.push_back((lattice * static_cast<double>(volume_.voxel_size)).cast<float>());
    out.normals.push_back(normal);
    if (options_.colors) {
      std::array<std::uint8_t, 3> color{};
      for (int ch = 0; ch < 3; ++ch) {
        const float value = (1.0f - t) * a.color[ch] + t * b.color[ch];
        color[ch] = static_cast<std::uint8_t>(std::clamp(std::lround(value), 0L, 255L));
      }
      out.colors.push_back(color);
    }
    return static_cast<std::uint32_t>(slot);
  }

  const HostVolume& volume_;
  const MeshOptions& options_;
  const BlockIndex& index_;
  std::array<const VolumeBlock*, 27> neighbours_{};
  std::vector<LocalVoxel> local_ = std::vector<LocalVoxel>(kGatherVoxels);
  // Vertex index per (axis, lower end) of the edges whose lower end lies in 0 .. kBlockSide.
  std::vector<int> edge_vertex_ =
      std::vector<int>(3 * (kBlockSide + 1) * (kBlockSide + 1) * (kBlockSide + 1));
};

// extract_mesh's arguments: a positive, finite voxel size and a positive min_weight.
Status check_options(const HostVolume& volume, const MeshOptions& options) {
  if (!(volume.voxel_size > 0.0f) || !std::isfinite(volume.voxel_size)) {
    return make_error(
        ErrorCode::kInvalidArgument,
        "extract_mesh: voxel size " + std::to_string(volume.voxel_size) + " m is not positive");
  }
  if (!(options.min_weight > 0.0f)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "extract_mesh: min_weight " + std::to_string(options.min_weight) +
                          " must be positive (weight 0 marks unobserved voxels)");
  }
  return {};
}

// "extract_mesh: block (x, y, z)", the start of a message about one block.
std::string block_message(const Eigen::Vector3i& c) {
  return "extract_mesh: block (" + std::to_string(c.x()) + ", " + std::to_string(c.y()) + ", " +
         std::to_string(c.z()) + ")";
}

// The blocks by key; an error when a block lies outside the lattice or appears twice.
Result<BlockIndex> index_blocks(const HostVolume& volume) {
  BlockIndex index;
  index.reserve(volume.blocks.size() * 2);
  for (std::size_t b = 0; b < volume.blocks.size(); ++b) {
    const Eigen::Vector3i& c = volume.blocks[b].coord;
    if (!mesh::block_in_range(c)) {
      return make_error(ErrorCode::kInvalidArgument,
                        block_message(c) + " is outside the supported lattice (|coordinate| < " +
                            std::to_string(mesh::kMaxBlockCoord) + ")");
    }
    if (!index.emplace(mesh::block_key(c), b).second) {
      return make_error(ErrorCode::kInvalidArgument,
                        block_message(c) + " appears twice in the snapshot");
    }
  }
  return index;
}

// The blocks in (z, y, x) coordinate order, so that the welded output does not depend on the
// snapshot order.
std::vector<const VolumeBlock*> coordinate_order(const HostVolume& volume) {
  std::vector<const VolumeBlock*> order;
  order.reserve(volume.blocks.size());
  for (const VolumeBlock& block : volume.blocks) order.push_back(&block);
  std::sort(order.begin(), order.end(), [](const VolumeBlock* a, const VolumeBlock* b) {
    return std::tie(a->coord.z(), a->coord.y(), a->coord.x()) <
           std::tie(b->coord.z(), b->coord.y(), b->coord.x());
  });
  return order;
}

// A block's part as a mesh of its own (its vertices are already unique within the block).
Mesh part_mesh(BlockPart& part, bool colors) {
  Mesh mesh;
  mesh.vertices = std::move(part.vertices);
  mesh.normals = std::move(part.normals);
  if (colors) mesh.colors = std::move(part.colors);
  mesh.triangles = std::move(part.triangles);
  return mesh;
}

// The mesh of each block (an empty part for nullptr), meshed by options.threads threads (0: one
// per core).
std::vector<BlockPart> mesh_blocks(const HostVolume& volume, const MeshOptions& options,
                                   const BlockIndex& index,
                                   const std::vector<const VolumeBlock*>& blocks) {
  std::vector<BlockPart> parts(blocks.size());
  unsigned threads = options.threads > 0 ? static_cast<unsigned>(options.threads)
                                         : std::max(1u, std::thread::hardware_concurrency());
  threads = static_cast<unsigned>(
      std::min<std::size_t>(threads, std::max<std::size_t>(1, blocks.size())));
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    Mesher mesher(volume, options, index);
    for (std::size_t n = next.fetch_add(1); n < blocks.size(); n = next.fetch_add(1)) {
      if (blocks[n] != nullptr) mesher.mesh_block(*blocks[n], parts[n]);
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& thread : pool) thread.join();
  return parts;
}

// One mesh from the parts, in their order: a vertex on a lattice edge that several parts share
// is kept once. Releases the parts as it goes.
Mesh weld(std::vector<BlockPart>& parts, bool colors) {
  Mesh result;
  std::size_t vertex_bound = 0, shared_bound = 0, triangle_count = 0;
  for (const BlockPart& part : parts) {
    vertex_bound += part.vertices.size();
    triangle_count += part.triangles.size();
    for (std::uint64_t key : part.edge_keys) shared_bound += (key & kSharedBit) != 0;
  }
  result.vertices.reserve(vertex_bound);
  result.normals.reserve(vertex_bound);
  if (colors) result.colors.reserve(vertex_bound);
  result.triangles.reserve(triangle_count);
  // Only edges on block faces can appear in several parts; the others are new vertices.
  EdgeVertexMap welded(shared_bound);
  std::vector<std::uint32_t> remap;
  for (BlockPart& part : parts) {
    remap.resize(part.vertices.size());
    for (std::size_t v = 0; v < part.vertices.size(); ++v) {
      const auto next_index = static_cast<std::uint32_t>(result.vertices.size());
      const std::uint64_t key = part.edge_keys[v];
      remap[v] = (key & kSharedBit) != 0 ? welded.find_or_insert(key, next_index) : next_index;
      if (remap[v] == next_index) {
        result.vertices.push_back(part.vertices[v]);
        result.normals.push_back(part.normals[v]);
        if (colors) result.colors.push_back(part.colors[v]);
      }
    }
    for (const auto& tri : part.triangles) {
      result.triangles.push_back({remap[tri[0]], remap[tri[1]], remap[tri[2]]});
    }
    part = BlockPart{};  // release as we go: the parts together are as large as the mesh
  }
  result.vertices.shrink_to_fit();
  result.normals.shrink_to_fit();
  result.colors.shrink_to_fit();
  return result;
}

}  // namespace

Result<Mesh> extract_mesh(const HostVolume& volume, const MeshOptions& options) {
  IMUFUSION_RETURN_IF_ERROR(check_options(volume, options));
  auto index = index_blocks(volume);
  if (!index.ok()) return index.error();
  std::vector<BlockPart> parts = mesh_blocks(volume, options, *index, coordinate_order(volume));
  return weld(parts, options.colors);
}

Result<std::vector<BlockMesh>> extract_block_meshes(const HostVolume& volume,
                                                    std::span<const Eigen::Vector3i> blocks,
                                                    const MeshOptions& options) {
  IMUFUSION_RETURN_IF_ERROR(check_options(volume, options));
  auto index = index_blocks(volume);
  if (!index.ok()) return index.error();
  std::vector<const VolumeBlock*> listed;
  listed.reserve(blocks.size());
  for (const Eigen::Vector3i& c : blocks) {
    if (!mesh::block_in_range(c)) {
      return make_error(ErrorCode::kInvalidArgument,
                        block_message(c) + " is outside the supported lattice");
    }
    const auto it = index->find(mesh::block_key(c));
    listed.push_back(it == index->end() ? nullptr : &volume.blocks[it->second]);
  }
  std::vector<BlockPart> parts = mesh_blocks(volume, options, *index, listed);
  std::vector<BlockMesh> meshes(blocks.size());
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    meshes[b].block = blocks[b];
    meshes[b].mesh = part_mesh(parts[b], options.colors);
  }
  return meshes;
}

}  // namespace imufusion

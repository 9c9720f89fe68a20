// glTF 2.0 export (binary .glb) and import through tinygltf, compiled here (header-only use: no
// image support, which meshes do not need).

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

// The library is often linked statically: renaming tinygltf's namespace keeps its symbols from
// clashing with an application's own copy of tinygltf.
#define tinygltf imufusion_tinygltf
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include "imufusion/mesh.hpp"
#include "io/atomic_file.hpp"
#include "mesh/mesh_internal.hpp"

namespace imufusion {
namespace {

constexpr int kArrayBuffer = TINYGLTF_TARGET_ARRAY_BUFFER;
constexpr int kElementArrayBuffer = TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER;

// Appends `bytes` to the buffer as a new buffer view (offsets stay 4-byte aligned: every view
// here is a multiple of 4 bytes long) and returns its index.
int add_view(tinygltf::Model& model, const void* bytes, std::size_t size, int target,
             std::size_t stride = 0) {
  auto& data = model.buffers[0].data;
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = data.size();
  view.byteLength = size;
  view.byteStride = stride;
  view.target = target;
  const auto* begin = static_cast<const unsigned char*>(bytes);
  data.insert(data.end(), begin, begin + size);
  model.bufferViews.push_back(view);
  return static_cast<int>(model.bufferViews.size() - 1);
}

int add_accessor(tinygltf::Model& model, int view, int component_type, int type, std::size_t count,
                 bool normalized = false) {
  tinygltf::Accessor accessor;
  accessor.bufferView = view;
  accessor.byteOffset = 0;
  accessor.componentType = component_type;
  accessor.type = type;
  accessor.count = count;
  accessor.normalized = normalized;
  model.accessors.push_back(accessor);
  return static_cast<int>(model.accessors.size() - 1);
}

tinygltf::Model make_model(const Mesh& mesh) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "imufusion";
  model.buffers.resize(1);
  const std::size_t n = mesh.vertices.size();

  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.material = 0;

  std::vector<float> floats(3 * n);
  for (std::size_t v = 0; v < n; ++v) {
    for (int a = 0; a < 3; ++a) floats[3 * v + static_cast<std::size_t>(a)] = mesh.vertices[v][a];
  }
  int view = add_view(model, floats.data(), floats.size() * sizeof(float), kArrayBuffer);
  const int position =
      add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
  // The spec requires the bounds of POSITION (validators recompute and compare them).
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  for (const auto& p : mesh.vertices) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  model.accessors[static_cast<std::size_t>(position)].minValues = {lo.x(), lo.y(), lo.z()};
  model.accessors[static_cast<std::size_t>(position)].maxValues = {hi.x(), hi.y(), hi.z()};
  primitive.attributes["POSITION"] = position;

  for (std::size_t v = 0; v < n; ++v) {
    for (int a = 0; a < 3; ++a) floats[3 * v + static_cast<std::size_t>(a)] = mesh.normals[v][a];
  }
  view = add_view(model, floats.data(), floats.size() * sizeof(float), kArrayBuffer);
  primitive.attributes["NORMAL"] =
      add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);

  if (!mesh.colors.empty()) {
    // Vertex attribute elements must start on 4-byte boundaries: RGB bytes with stride 4.
    std::vector<std::uint8_t> rgb(4 * n, 0);
    for (std::size_t v = 0; v < n; ++v) std::memcpy(&rgb[4 * v], mesh.colors[v].data(), 3);
    view = add_view(model, rgb.data(), rgb.size(), kArrayBuffer, 4);
    primitive.attributes["COLOR_0"] = add_accessor(
        model, view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_TYPE_VEC3, n, true);
  }

  std::vector<std::uint32_t> indices;
  indices.reserve(3 * mesh.triangles.size());
  for (const auto& tri : mesh.triangles) indices.insert(indices.end(), tri.begin(), tri.end());
  view =
      add_view(model, indices.data(), indices.size() * sizeof(std::uint32_t), kElementArrayBuffer);
  primitive.indices = add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                                   TINYGLTF_TYPE_SCALAR, indices.size());

  tinygltf::Material material;
  material.name = "scan";
  material.pbrMetallicRoughness.baseColorFactor = {1.0, 1.0, 1.0, 1.0};
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 1.0;
  // Scans are open surfaces that a viewer often sees from behind through a hole.
  material.doubleSided = true;
  model.materials.push_back(material);

  tinygltf::Mesh gltf_mesh;
  gltf_mesh.name = "scan";
  gltf_mesh.primitives.push_back(primitive);
  model.meshes.push_back(gltf_mesh);
  tinygltf::Node node;
  node.mesh = 0;
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  return model;
}

// Element `i`, component `c` of an accessor as a float (normalized integers mapped to [0, 1]
// or [-1, 1] as the spec says).
class AccessorView {
 public:
  static Result<AccessorView> open(const tinygltf::Model& model, int index,
                                   const std::string& what) {
    if (index < 0 || static_cast<std::size_t>(index) >= model.accessors.size()) {
      return make_error(ErrorCode::kParseError,
                        what + ": accessor " + std::to_string(index) + " does not exist");
    }
    const tinygltf::Accessor& accessor = model.accessors[static_cast<std::size_t>(index)];
    if (accessor.sparse.isSparse || accessor.bufferView < 0) {
      return make_error(ErrorCode::kUnsupported,
                        what + ": accessor " + std::to_string(index) + " is sparse or has no data");
    }
    if (static_cast<std::size_t>(accessor.bufferView) >= model.bufferViews.size() ||
        model.bufferViews[static_cast<std::size_t>(accessor.bufferView)].buffer < 0 ||
        static_cast<std::size_t>(
            model.bufferViews[static_cast<std::size_t>(accessor.bufferView)].buffer) >=
            model.buffers.size()) {
      return make_error(ErrorCode::kParseError, what + ": accessor " + std::to_string(index) +
                                                    " refers to a missing buffer");
    }
    const auto& view = model.bufferViews[static_cast<std::size_t>(accessor.bufferView)];
    const auto& buffer = model.buffers[static_cast<std::size_t>(view.buffer)];
    AccessorView out;
    out.accessor_ = &accessor;
    out.components_ = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(accessor.type));
    const int component_size =
        tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(accessor.componentType));
    const int stride = accessor.ByteStride(view);
    if (out.components_ <= 0 || component_size <= 0 || stride <= 0) {
      return make_error(ErrorCode::kParseError,
                        what + ": accessor " + std::to_string(index) + " has a bad type");
    }
    out.component_size_ = static_cast<std::size_t>(component_size);
    out.stride_ = static_cast<std::size_t>(stride);
    out.begin_ = view.byteOffset + accessor.byteOffset;
    const std::size_t element = out.component_size_ * static_cast<std::size_t>(out.components_);
    const std::size_t needed =
        accessor.count == 0 ? 0 : out.stride_ * (accessor.count - 1) + element;
    if (out.begin_ + needed > buffer.data.size() ||
        accessor.byteOffset + needed > view.byteLength) {
      return make_error(ErrorCode::kParseError,
                        what + ": accessor " + std::to_string(index) + " runs past its buffer");
    }
    out.data_ = buffer.data.data();
    return out;
  }

  std::size_t count() const { return accessor_->count; }
  int components() const { return components_; }

  double at(std::size_t i, int c) const {
    const unsigned char* p =
        data_ + begin_ + stride_ * i + component_size_ * static_cast<std::size_t>(c);
    switch (accessor_->componentType) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float f = 0;
        std::memcpy(&f, p, sizeof(f));
        return f;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return accessor_->normalized ? *p / 255.0 : *p;
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const auto b = static_cast<std::int8_t>(*p);
        return accessor_->normalized ? std::max(b / 127.0, -1.0) : b;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        std::uint16_t s = 0;
        std::memcpy(&s, p, sizeof(s));
        return accessor_->normalized ? s / 65535.0 : s;
      }
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        std::int16_t s = 0;
        std::memcpy(&s, p, sizeof(s));
        return accessor_->normalized ? std::max(s / 32767.0, -1.0) : s;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        std::uint32_t u = 0;
        std::memcpy(&u, p, sizeof(u));
        return u;
      }
      default:
        return 0.0;
    }
  }

 private:
  const tinygltf::Accessor* accessor_ = nullptr;
  const unsigned char* data_ = nullptr;
  std::size_t begin_ = 0, stride_ = 0, component_size_ = 0;
  int components_ = 0;
};

// Appends the primitive's POSITION (VEC3) to mesh.vertices; returns how many.
Result<std::size_t> append_positions(const tinygltf::Model& model,
                                     const tinygltf::Primitive& primitive, const std::string& what,
                                     Mesh& mesh) {
  const auto position_it = primitive.attributes.find("POSITION");
  if (position_it == primitive.attributes.end()) {
    return make_error(ErrorCode::kParseError, what + ": a primitive has no POSITION");
  }
  auto positions = AccessorView::open(model, position_it->second, what);
  if (!positions.ok()) return positions.error();
  if (positions->components() != 3) {
    return make_error(ErrorCode::kParseError, what + ": POSITION is not VEC3");
  }
  const std::size_t n = positions->count();
  for (std::size_t v = 0; v < n; ++v) {
    const Eigen::Vector3f p(static_cast<float>(positions->at(v, 0)),
                            static_cast<float>(positions->at(v, 1)),
                            static_cast<float>(positions->at(v, 2)));
    if (!p.allFinite()) {
      return make_error(ErrorCode::kParseError,
                        what + ": POSITION " + std::to_string(v) + " is not finite");
    }
    mesh.vertices.push_back(p);
  }
  return n;
}

// The NORMAL accessor `index` (VEC3, n of them) into mesh.normals from `base` on; as in read_ply,
// an entry that is not finite or beyond 1e6 reads as 0.
Status read_normals(const tinygltf::Model& model, int index, const std::string& what,
                    std::size_t base, std::size_t n, Mesh& mesh) {
  auto normals = AccessorView::open(model, index, what);
  if (!normals.ok()) return normals.error();
  if (normals->components() != 3 || normals->count() != n) {
    return make_error(ErrorCode::kParseError, what + ": NORMAL does not match POSITION");
  }
  for (std::size_t v = 0; v < n; ++v) {
    for (int a = 0; a < 3; ++a) {
      const double entry = normals->at(v, a);
      mesh.normals[base + v][a] = std::abs(entry) <= 1e6 ? static_cast<float>(entry) : 0.0f;
    }
  }
  return {};
}

// The COLOR_0 accessor `index` (RGB or RGBA in [0, 1], n of them) into mesh.colors from `base`
// on, as bytes; alpha is dropped, non-finite values read as 0.
Status read_colors(const tinygltf::Model& model, int index, const std::string& what,
                   std::size_t base, std::size_t n, Mesh& mesh) {
  auto colors = AccessorView::open(model, index, what);
  if (!colors.ok()) return colors.error();
  if (colors->components() < 3 || colors->count() != n) {
    return make_error(ErrorCode::kParseError, what + ": COLOR_0 does not match POSITION");
  }
  for (std::size_t v = 0; v < n; ++v) {
    for (int c = 0; c < 3; ++c) {
      const double raw = colors->at(v, c);
      const double value = std::isfinite(raw) ? std::clamp(raw, 0.0, 1.0) * 255.0 : 0.0;
      mesh.colors[base + v][static_cast<std::size_t>(c)] =
          static_cast<std::uint8_t>(std::lround(value));
    }
  }
  return {};
}

// The primitive's vertex indices (unsigned integers); 0 .. n-1 when it has none.
Result<std::vector<std::uint32_t>> read_indices(const tinygltf::Model& model,
                                                const tinygltf::Primitive& primitive,
                                                const std::string& what, std::size_t n) {
  std::vector<std::uint32_t> indices;
  if (primitive.indices >= 0) {
    auto view = AccessorView::open(model, primitive.indices, what);
    if (!view.ok()) return view.error();
    const int type = model.accessors[static_cast<std::size_t>(primitive.indices)].componentType;
    if (type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
        type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) {
      return make_error(ErrorCode::kParseError,
                        what + ": indices are not unsigned integers (component type " +
                            std::to_string(type) + ")");
    }
    indices.resize(view->count());
    for (std::size_t i = 0; i < indices.size(); ++i) {
      indices[i] = static_cast<std::uint32_t>(view->at(i, 0));
    }
  } else {
    indices.resize(n);
    for (std::size_t i = 0; i < n; ++i) indices[i] = static_cast<std::uint32_t>(i);
  }
  return indices;
}

// Appends the triangles of `indices` (triples, each below n) to the mesh, offset by `base`.
Status append_triangles(const std::vector<std::uint32_t>& indices, const std::string& what,
                        std::size_t base, std::size_t n, Mesh& mesh) {
  if (indices.size() % 3 != 0) {
    return make_error(ErrorCode::kParseError,
                      what + ": " + std::to_string(indices.size()) + " indices are not triangles");
  }
  for (std::size_t i = 0; i < indices.size(); i += 3) {
    std::array<std::uint32_t, 3> tri{};
    for (std::size_t k = 0; k < 3; ++k) {
      if (indices[i + k] >= n) {
        return make_error(ErrorCode::kParseError,
                          what + ": index " + std::to_string(indices[i + k]) + " is beyond " +
                              std::to_string(n) + " vertices");
      }
      tri[k] = static_cast<std::uint32_t>(base + indices[i + k]);
    }
    mesh.triangles.push_back(tri);
  }
  return {};
}

// Appends a triangle primitive to the mesh. all_normals / all_colors turn false when it lacks
// NORMAL / COLOR_0; its vertices hold +z and black until the caller replaces them.
Status append_primitive(const tinygltf::Model& model, const tinygltf::Primitive& primitive,
                        const std::string& what, Mesh& mesh, bool& all_normals, bool& all_colors) {
  const std::size_t base = mesh.vertices.size();
  auto n = append_positions(model, primitive, what, mesh);
  if (!n.ok()) return n.error();
  mesh.normals.resize(base + *n, Eigen::Vector3f::UnitZ());
  mesh.colors.resize(base + *n, {0, 0, 0});

  const auto normal_it = primitive.attributes.find("NORMAL");
  if (normal_it == primitive.attributes.end()) {
    all_normals = false;
  } else {
    IMUFUSION_RETURN_IF_ERROR(read_normals(model, normal_it->second, what, base, *n, mesh));
  }
  const auto color_it = primitive.attributes.find("COLOR_0");
  if (color_it == primitive.attributes.end()) {
    all_colors = false;
  } else {
    IMUFUSION_RETURN_IF_ERROR(read_colors(model, color_it->second, what, base, *n, mesh));
  }
  auto indices = read_indices(model, primitive, what, *n);
  if (!indices.ok()) return indices.error();
  return append_triangles(*indices, what, base, *n, mesh);
}

// tinygltf's file callbacks for external buffers, through read_file_bytes: regular files only
// (its own opened a FIFO and waited for a writer), up to the size limit.
bool file_exists(const std::string& path, void*) {
  std::error_code ec;
  return std::filesystem::exists(path, ec);
}

bool read_whole_file(std::vector<unsigned char>* out, std::string* error, const std::string& path,
                     void*) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes.ok()) {
    if (error != nullptr) *error += bytes.error().message + "\n";
    return false;
  }
  if (bytes->empty()) {
    if (error != nullptr) *error += path + ": empty file\n";
    return false;
  }
  *out = std::move(*bytes);
  return true;
}

tinygltf::FsCallbacks file_callbacks() {
  tinygltf::FsCallbacks callbacks{};
  callbacks.FileExists = file_exists;
  callbacks.ExpandFilePath = tinygltf::ExpandFilePath;
  callbacks.ReadWholeFile = read_whole_file;
  callbacks.WriteWholeFile = tinygltf::WriteWholeFile;
  callbacks.user_data = nullptr;
  return callbacks;
}

}  // namespace

Status write_glb(const std::filesystem::path& path, const Mesh& mesh) {
  const std::string what = "write_glb " + path.string();
  IMUFUSION_RETURN_IF_ERROR(mesh::check_mesh_for(mesh, what));
  if (mesh.triangles.empty()) {
    return make_error(ErrorCode::kInvalidArgument,
                      what + ": the mesh has no triangles (glTF accessors cannot be empty)");
  }
  const tinygltf::Model model = make_model(mesh);
  std::ostringstream stream;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&model, stream, false, true)) {
    return make_error(ErrorCode::kInternal, what + ": tinygltf could not serialize the mesh");
  }
  return io::write_text_atomically(path, stream.str());
}

Result<Mesh> read_gltf(const std::filesystem::path& path) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes.ok()) return bytes.error();
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return mesh::parse_gltf(*bytes, extension == ".glb", path.parent_path(), path.string());
}

namespace mesh {

Result<Mesh> parse_gltf(const std::vector<std::uint8_t>& bytes, bool binary,
                        const std::filesystem::path& base_directory, const std::string& name) {
  if (bytes.size() > std::numeric_limits<unsigned int>::max()) {
    return make_error(ErrorCode::kUnsupported, name + ": larger than tinygltf reads (4 GiB)");
  }
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  loader.SetFsCallbacks(file_callbacks());
  std::string error, warning;
  const auto size = static_cast<unsigned int>(bytes.size());
  const bool loaded = binary
                          ? loader.LoadBinaryFromMemory(&model, &error, &warning, bytes.data(),
                                                        size, base_directory.string())
                          : loader.LoadASCIIFromString(&model, &error, &warning,
                                                       reinterpret_cast<const char*>(bytes.data()),
                                                       size, base_directory.string());
  if (!loaded) return make_error(ErrorCode::kParseError, name + ": " + error);

  Mesh mesh;
  bool all_normals = true, all_colors = true;
  for (const auto& gltf_mesh : model.meshes) {
    for (const auto& primitive : gltf_mesh.primitives) {
      if (primitive.mode != TINYGLTF_MODE_TRIANGLES) continue;
      IMUFUSION_RETURN_IF_ERROR(
          append_primitive(model, primitive, name, mesh, all_normals, all_colors));
    }
  }
  if (!all_colors) mesh.colors.clear();
  if (!all_normals) compute_vertex_normals(mesh);
  return mesh;
}

}  // namespace mesh

}  // namespace imufusion

// PLY (Turk 1994) writer and binary little-endian reader.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "imufusion/mesh.hpp"
#include "io/atomic_file.hpp"
#include "mesh/mesh_internal.hpp"

namespace imufusion {
namespace {

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t value) {
  for (int b = 0; b < 4; ++b) out.push_back(static_cast<std::uint8_t>(value >> (8 * b)));
}

void put_f32(std::vector<std::uint8_t>& out, float value) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, &value, sizeof(bits));
  put_u32(out, bits);
}

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::optional<PlyType> parse_type(const std::string& name) {
  if (name == "char" || name == "int8") return PlyType::kInt8;
  if (name == "uchar" || name == "uint8") return PlyType::kUint8;
  if (name == "short" || name == "int16") return PlyType::kInt16;
  if (name == "ushort" || name == "uint16") return PlyType::kUint16;
  if (name == "int" || name == "int32") return PlyType::kInt32;
  if (name == "uint" || name == "uint32") return PlyType::kUint32;
  if (name == "float" || name == "float32") return PlyType::kFloat32;
  if (name == "double" || name == "float64") return PlyType::kFloat64;
  return std::nullopt;
}

std::size_t type_size(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

struct Property {
  std::string name;
  PlyType type = PlyType::kFloat32;
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct Element {
  std::string name;
  std::size_t count = 0;
  std::vector<Property> properties;
};

// Reads little-endian values from the body, failing (not reading past the end) when short.
class Reader {
 public:
  Reader(const std::vector<std::uint8_t>& bytes, std::size_t offset)
      : bytes_(bytes), offset_(offset) {}

  bool read(PlyType type, double& value) {
    const std::size_t size = type_size(type);
    if (bytes_.size() - offset_ < size) return false;
    std::uint64_t raw = 0;
    for (std::size_t b = 0; b < size; ++b) {
      raw |= static_cast<std::uint64_t>(bytes_[offset_ + b]) << (8 * b);
    }
    offset_ += size;
    switch (type) {
      case PlyType::kInt8:
        value = static_cast<std::int8_t>(raw);
        break;
      case PlyType::kUint8:
        value = static_cast<double>(raw);
        break;
      case PlyType::kInt16:
        value = static_cast<std::int16_t>(raw);
        break;
      case PlyType::kUint16:
        value = static_cast<double>(raw);
        break;
      case PlyType::kInt32:
        value = static_cast<std::int32_t>(raw);
        break;
      case PlyType::kUint32:
        value = static_cast<double>(raw);
        break;
      case PlyType::kFloat32: {
        float f = 0;
        const auto bits = static_cast<std::uint32_t>(raw);
        std::memcpy(&f, &bits, sizeof(f));
        value = f;
        break;
      }
      case PlyType::kFloat64:
        std::memcpy(&value, &raw, sizeof(value));
        break;
    }
    return true;
  }

 private:
  const std::vector<std::uint8_t>& bytes_;
  std::size_t offset_;
};

std::uint8_t to_color_byte(double value, PlyType type) {
  if (type == PlyType::kFloat32 || type == PlyType::kFloat64) value *= 255.0;  // [0, 1] colours
  if (type == PlyType::kUint16) value /= 257.0;
  if (!std::isfinite(value)) return 0;
  return static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.0, 255.0)));
}

// A malformed file: "<file>: <message>".
Error parse_error(const std::string& file, const std::string& message) {
  return make_error(ErrorCode::kParseError, file + ": " + message);
}

// The header's elements in file order, and where the binary body starts (bytes into the file).
struct PlyHeader {
  std::vector<Element> elements;
  std::size_t body_offset = 0;
};

// The header line starting at `offset` (without its '\n' or "\r\n"), moving `offset` past it;
// nullopt when no '\n' follows.
std::optional<std::string> next_line(const std::vector<std::uint8_t>& bytes, std::size_t& offset) {
  const auto begin = bytes.begin() + static_cast<std::ptrdiff_t>(offset);
  const auto end = std::find(begin, bytes.end(), std::uint8_t{'\n'});
  if (end == bytes.end()) return std::nullopt;
  std::string line(begin, end);
  offset = static_cast<std::size_t>(end - bytes.begin()) + 1;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

// The words after "format": only binary_little_endian is read. `where` ("line N: ") prefixes
// the message.
Status check_format(std::istringstream& words, const std::string& file, const std::string& where) {
  std::string format;
  words >> format;
  if (format != "binary_little_endian") {
    return make_error(ErrorCode::kUnsupported,
                      file + ": " + where + "format '" + format +
                          "' is not supported (only binary_little_endian)");
  }
  return {};
}

// The words after "element": "<name> <count>".
Result<Element> parse_element(std::istringstream& words, const std::string& file,
                              const std::string& where) {
  Element element;
  long long count = -1;
  words >> element.name >> count;
  if (!words || count < 0) return parse_error(file, where + "malformed element line");
  element.count = static_cast<std::size_t>(count);
  return element;
}

// The words after "property": "<type> <name>" or "list <count type> <item type> <name>".
Result<Property> parse_property(std::istringstream& words, const std::string& file,
                                const std::string& where) {
  Property property;
  std::string type;
  words >> type;
  if (type == "list") {
    std::string count_type, item_type;
    words >> count_type >> item_type >> property.name;
    const auto ct = parse_type(count_type), it = parse_type(item_type);
    if (!ct || !it) return parse_error(file, where + "unknown list type");
    property.is_list = true;
    property.count_type = *ct;
    property.type = *it;
  } else {
    words >> property.name;
    const auto t = parse_type(type);
    if (!t) return parse_error(file, where + "unknown property type '" + type + "'");
    property.type = *t;
  }
  if (property.name.empty()) return parse_error(file, where + "property without a name");
  return property;
}

// The text header: the "ply" magic, then lines up to "end_header".
Result<PlyHeader> parse_header(const std::vector<std::uint8_t>& bytes, const std::string& file) {
  PlyHeader header;
  int line_number = 0;
  bool format_seen = false;
  for (;;) {
    const std::optional<std::string> line = next_line(bytes, header.body_offset);
    if (!line) return parse_error(file, "no end_header line");
    ++line_number;
    const std::string where = "line " + std::to_string(line_number) + ": ";
    std::istringstream words(*line);
    std::string keyword;
    words >> keyword;
    if (line_number == 1) {
      if (keyword != "ply") return parse_error(file, "not a PLY file (no 'ply' magic)");
      continue;
    }
    if (keyword == "end_header") break;
    if (keyword == "comment" || keyword == "obj_info" || keyword.empty()) continue;
    if (keyword == "format") {
      IMUFUSION_RETURN_IF_ERROR(check_format(words, file, where));
      format_seen = true;
    } else if (keyword == "element") {
      auto element = parse_element(words, file, where);
      if (!element.ok()) return element.error();
      header.elements.push_back(*element);
    } else if (keyword == "property") {
      if (header.elements.empty()) return parse_error(file, where + "property before any element");
      auto property = parse_property(words, file, where);
      if (!property.ok()) return property.error();
      header.elements.back().properties.push_back(*property);
    } else {
      return parse_error(file, where + "unknown header keyword '" + keyword + "'");
    }
  }
  if (!format_seen) return parse_error(file, "no format line");
  return header;
}

// Columns of a vertex element's attributes among its properties (-1: absent).
struct VertexColumns {
  std::array<int, 3> position, normal, color;

  bool has_position() const { return position[0] >= 0 && position[1] >= 0 && position[2] >= 0; }
  bool has_normals() const { return normal[0] >= 0 && normal[1] >= 0 && normal[2] >= 0; }
  bool has_colors() const { return color[0] >= 0 && color[1] >= 0 && color[2] >= 0; }
};

VertexColumns vertex_columns(const Element& element) {
  auto column = [&](const char* property) {
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      if (element.properties[p].name == property) return static_cast<int>(p);
    }
    return -1;
  };
  return {{column("x"), column("y"), column("z")},
          {column("nx"), column("ny"), column("nz")},
          {column("red"), column("green"), column("blue")}};
}

// Reads the body's elements, in header order, into a mesh: "vertex" (x y z, optional nx ny nz
// and red green blue) and the polygons of "face" (fanned into triangles); other elements and
// properties are read past.
class BodyReader {
 public:
  BodyReader(const std::vector<std::uint8_t>& bytes, std::size_t body_offset,
             const std::string& file)
      : reader_(bytes, body_offset), body_bytes_(bytes.size() - body_offset), file_(file) {}

  Status read_element(const Element& element) {
    // Items without properties hold no bytes: whatever their count, there is nothing to read
    // (and looping over a count of 1e18 would never end).
    if (element.properties.empty() && element.name != "vertex") return {};
    // Each item takes at least its scalars and list counts: refuse counts the file cannot hold
    // before allocating for them.
    std::size_t min_item_size = 0;
    for (const Property& property : element.properties) {
      min_item_size += type_size(property.is_list ? property.count_type : property.type);
    }
    if (min_item_size > 0 && element.count > body_bytes_ / min_item_size) {
      return parse_error(file_, "header declares " + std::to_string(element.count) + " " +
                                    element.name + " items, more than the file holds (truncated)");
    }
    const bool is_vertex = element.name == "vertex";
    const VertexColumns columns = vertex_columns(element);
    if (is_vertex) {
      // Faces index one vertex list; a second would leave the first's colours unmatched.
      if (vertex_read_) return parse_error(file_, "a second vertex element (one is allowed)");
      vertex_read_ = true;
      if (!columns.has_position()) return parse_error(file_, "vertex element lacks x, y or z");
      has_normals_ = columns.has_normals();
      mesh_.vertices.resize(element.count);
      mesh_.normals.assign(element.count, Eigen::Vector3f::UnitZ());
      if (columns.has_colors()) mesh_.colors.resize(element.count);
    }
    values_.assign(element.properties.size(), 0.0);
    for (std::size_t item = 0; item < element.count; ++item) {
      IMUFUSION_RETURN_IF_ERROR(read_item(element, item));
      if (is_vertex) IMUFUSION_RETURN_IF_ERROR(store_vertex(element, columns, item));
    }
    return {};
  }

  // The mesh once every element is read: its triangles checked against the vertices, and
  // normals computed from the triangles when the file has none.
  Result<Mesh> finish() {
    for (std::size_t t = 0; t < mesh_.triangles.size(); ++t) {
      for (std::uint32_t v : mesh_.triangles[t]) {
        if (v >= mesh_.vertices.size()) {
          return parse_error(file_, "triangle " + std::to_string(t) + " uses vertex " +
                                        std::to_string(v) + " of " +
                                        std::to_string(mesh_.vertices.size()));
        }
      }
    }
    if (!has_normals_) mesh::compute_vertex_normals(mesh_);
    return std::move(mesh_);
  }

 private:
  Error truncated(const Element& element, std::size_t item) const {
    return parse_error(file_, "truncated in " + element.name + " " + std::to_string(item));
  }

  // One item's properties: scalars into values_, lists into polygon_ (a face's vertex indices
  // become triangles).
  Status read_item(const Element& element, std::size_t item) {
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const Property& property = element.properties[p];
      if (!property.is_list) {
        if (!reader_.read(property.type, values_[p])) return truncated(element, item);
        continue;
      }
      IMUFUSION_RETURN_IF_ERROR(read_list(element, property, item));
      if (element.name == "face" &&
          (property.name == "vertex_indices" || property.name == "vertex_index")) {
        if (polygon_.size() < 3) {
          return parse_error(file_, "face " + std::to_string(item) + " has " +
                                        std::to_string(polygon_.size()) + " vertices");
        }
        for (std::size_t k = 1; k + 1 < polygon_.size(); ++k) {
          mesh_.triangles.push_back({polygon_[0], polygon_[k], polygon_[k + 1]});
        }
      }
    }
    return {};
  }

  // A list property's count and entries into polygon_, each a vertex index in uint32 range.
  Status read_list(const Element& element, const Property& property, std::size_t item) {
    double count = 0;
    if (!reader_.read(property.count_type, count)) return truncated(element, item);
    // Each entry takes a byte or more: a count beyond the file's size (or a float count that is
    // negative, NaN or 1e30) is corrupt.
    if (!(count >= 0.0 && count <= static_cast<double>(body_bytes_))) {
      return parse_error(file_, element.name + " " + std::to_string(item) + " has list count " +
                                    std::to_string(count));
    }
    polygon_.clear();
    for (std::size_t k = 0; k < static_cast<std::size_t>(count); ++k) {
      double index = 0;
      if (!reader_.read(property.type, index)) return truncated(element, item);
      if (!(index >= 0.0 && index < 4294967296.0)) {
        return parse_error(file_, element.name + " " + std::to_string(item) + " has vertex index " +
                                      std::to_string(index));
      }
      polygon_.push_back(static_cast<std::uint32_t>(index));
    }
    return {};
  }

  // Vertex `item` from values_: its position (finite in float), normal (entries beyond 1e6 read
  // as 0) and colour (bytes).
  Status store_vertex(const Element& element, const VertexColumns& columns, std::size_t item) {
    for (int a = 0; a < 3; ++a) {
      const double x = values_[static_cast<std::size_t>(columns.position[a])];
      if (!(std::abs(x) <= std::numeric_limits<float>::max())) {
        return parse_error(
            file_, "vertex " + std::to_string(item) + " has coordinate " + std::to_string(x));
      }
      mesh_.vertices[item][a] = static_cast<float>(x);
      if (has_normals_) {
        const double n = values_[static_cast<std::size_t>(columns.normal[a])];
        mesh_.normals[item][a] = std::abs(n) <= 1e6 ? static_cast<float>(n) : 0.0f;
      }
      if (!mesh_.colors.empty()) {
        const auto c = static_cast<std::size_t>(columns.color[a]);
        mesh_.colors[item][static_cast<std::size_t>(a)] =
            to_color_byte(values_[c], element.properties[c].type);
      }
    }
    return {};
  }

  Reader reader_;
  std::size_t body_bytes_;  // from the end of the header to the end of the file
  const std::string& file_;
  Mesh mesh_;
  bool vertex_read_ = false;            // the vertex element is read (or being read)
  bool has_normals_ = false;            // the vertex element has nx, ny and nz
  std::vector<double> values_;          // the current item's scalar properties, by column
  std::vector<std::uint32_t> polygon_;  // the current item's last list
};

}  // namespace

Status write_ply(const std::filesystem::path& path, const Mesh& mesh) {
  IMUFUSION_RETURN_IF_ERROR(mesh::check_mesh_for(mesh, "write_ply " + path.string()));
  const bool colored = !mesh.colors.empty();
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment generated by imufusion (metres)\n"
         << "element vertex " << mesh.vertices.size() << "\n"
         << "property float x\nproperty float y\nproperty float z\n"
         << "property float nx\nproperty float ny\nproperty float nz\n";
  if (colored) header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  header << "element face " << mesh.triangles.size() << "\n"
         << "property list uchar uint vertex_indices\nend_header\n";
  const std::string head = header.str();

  std::vector<std::uint8_t> body;
  body.reserve(mesh.vertices.size() * (colored ? 27 : 24) + mesh.triangles.size() * 13);
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    for (int a = 0; a < 3; ++a) put_f32(body, mesh.vertices[v][a]);
    for (int a = 0; a < 3; ++a) put_f32(body, mesh.normals[v][a]);
    if (colored) body.insert(body.end(), mesh.colors[v].begin(), mesh.colors[v].end());
  }
  for (const auto& tri : mesh.triangles) {
    body.push_back(3);
    for (std::uint32_t index : tri) put_u32(body, index);
  }
  return io::write_file_atomically(path, [&](std::FILE* file) -> Status {
    if (std::fwrite(head.data(), 1, head.size(), file) != head.size() ||
        (!body.empty() && std::fwrite(body.data(), 1, body.size(), file) != body.size())) {
      return make_error(ErrorCode::kIoError, "write_ply: cannot write " + path.string());
    }
    return {};
  });
}

Result<Mesh> read_ply(const std::filesystem::path& path) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes.ok()) return bytes.error();
  return mesh::parse_ply(*bytes, path.string());
}

namespace mesh {

Result<Mesh> parse_ply(const std::vector<std::uint8_t>& bytes, const std::string& name) {
  auto header = parse_header(bytes, name);
  if (!header.ok()) return header.error();
  BodyReader body(bytes, header->body_offset, name);
  for (const Element& element : header->elements) {
    IMUFUSION_RETURN_IF_ERROR(body.read_element(element));
  }
  return body.finish();
}

}  // namespace mesh

}  // namespace imufusion

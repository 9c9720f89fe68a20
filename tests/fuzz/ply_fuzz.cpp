// libFuzzer harness: one file's bytes through the PLY reader (read_ply's in-memory body,
// mesh_internal.hpp). A mesh it returns must pass check_mesh: finite positions and normals,
// triangles on existing vertices. Built and run by .ci/run (clang -fsanitize=fuzzer,address,
// undefined).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "mesh/mesh_internal.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::vector<std::uint8_t> bytes(data, data + size);
  const auto mesh = imufusion::mesh::parse_ply(bytes, "fuzz.ply");
  if (mesh.ok() && !imufusion::check_mesh(*mesh).ok()) __builtin_trap();
  return 0;
}

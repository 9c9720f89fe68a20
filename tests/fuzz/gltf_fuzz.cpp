// libFuzzer harness: one file's bytes through the glTF reader (read_gltf's in-memory body,
// mesh_internal.hpp): binary glTF when the bytes start with the "glTF" magic, JSON otherwise.
// External buffers are looked up in a directory that does not exist. A mesh it returns must pass
// check_mesh. Built and run by .ci/run (clang -fsanitize=fuzzer,address,undefined).

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "mesh/mesh_internal.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::vector<std::uint8_t> bytes(data, data + size);
  const bool binary = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  const auto mesh =
      imufusion::mesh::parse_gltf(bytes, binary, "/nonexistent-imufusion-fuzz", "fuzz.gltf");
  if (mesh.ok() && !imufusion::check_mesh(*mesh).ok()) __builtin_trap();
  return 0;
}

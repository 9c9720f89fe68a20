#include "core/state_archive.hpp"

#include <array>
#include <cstring>

namespace imufusion {

void StateArchive::fail(const std::string& what) {
  if (error_.empty()) error_ = what;
}

void StateArchive::raw(void* data, std::size_t size) {
  if (!ok()) return;
  if (!reading_) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    output_.insert(output_.end(), p, p + size);
    return;
  }
  if (size > input_.size() - offset_) {
    fail("truncated at byte " + std::to_string(offset_) + ": a field of " + std::to_string(size) +
         " bytes, " + std::to_string(input_.size() - offset_) + " left");
    return;
  }
  std::memcpy(data, input_.data() + offset_, size);
  offset_ += size;
}

std::size_t StateArchive::count(std::size_t size, std::size_t element_bytes) {
  auto n = static_cast<std::uint64_t>(size);
  const std::size_t at = offset_;
  raw(&n, sizeof n);
  if (reading_ && ok() && n > (input_.size() - offset_) / element_bytes) {
    fail("bad size at byte " + std::to_string(at) + ": " + std::to_string(n) + " elements, only " +
         std::to_string(input_.size() - offset_) + " bytes left");
    return 0;
  }
  return static_cast<std::size_t>(n);
}

std::uint32_t crc32(std::span<const std::uint8_t> bytes) {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) != 0 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::uint8_t b : bytes) c = table[(c ^ b) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

}  // namespace imufusion

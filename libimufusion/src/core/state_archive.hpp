#pragma once
// StateArchive: the fields of a saved scan (Reconstructor::save / load) written to or read from
// bytes by one description per type, so that what is written and what is read cannot drift
// apart. A type describes itself with a member `void describe(StateArchive&)` or a free
// `describe(StateArchive&, T&)` listing its fields; reading assigns them, writing only reads them.
// Little-endian, fixed-width: numbers as their bytes, bool as one byte, containers as a uint64
// count then the elements. A read past the end or an impossible count stops the archive with an
// error naming the byte offset; the fields read so far are then partial and must be discarded.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace imufusion {

static_assert(std::endian::native == std::endian::little, "the state format is little-endian");

class StateArchive {
 public:
  static StateArchive writer() { return StateArchive(); }
  static StateArchive reader(std::span<const std::uint8_t> bytes) {
    StateArchive a;
    a.reading_ = true;
    a.input_ = bytes;
    return a;
  }

  bool reading() const { return reading_; }
  bool ok() const { return error_.empty(); }
  /// The first failure ("truncated at byte N: ..."), empty while ok().
  const std::string& error() const { return error_; }
  /// Stops the archive (the first failure is kept); later fields are skipped.
  void fail(const std::string& what);
  /// Bytes consumed while reading (the offset of the next field).
  std::size_t offset() const { return offset_; }
  /// What has been written.
  const std::vector<std::uint8_t>& bytes() const { return output_; }

  template <typename... T>
  void operator()(T&... fields) {
    (field(fields), ...);
  }

 private:
  StateArchive() = default;
  void raw(void* data, std::size_t size);
  // Writes the count of a sequence or reads it, failing when it claims more elements of at least
  // `element_bytes` each than the input has left.
  std::size_t count(std::size_t size, std::size_t element_bytes);

  template <typename T>
  static constexpr bool kPlain = std::is_arithmetic_v<T> || std::is_enum_v<T>;

  template <typename T>
  void field(T& x);
  template <typename T>
  void sequence(T& container);

  bool reading_ = false;
  std::span<const std::uint8_t> input_;
  std::size_t offset_ = 0;
  std::vector<std::uint8_t> output_;
  std::string error_;
};

template <typename T>
struct IsSequence : std::false_type {};
template <typename T>
struct IsSequence<std::vector<T>> : std::true_type {};
template <typename T>
struct IsSequence<std::deque<T>> : std::true_type {};

template <typename T>
void StateArchive::sequence(T& container) {
  using Element = typename T::value_type;
  const std::size_t n = count(container.size(), kPlain<Element> ? sizeof(Element) : 1);
  if (!ok()) return;
  if (reading_) container.resize(n);
  if constexpr (kPlain<Element> && !std::is_same_v<Element, bool> &&
                requires { container.data(); }) {
    raw(container.data(), n * sizeof(Element));
  } else {
    for (Element& e : container) {
      if (!ok()) return;
      field(e);
    }
  }
}

template <typename T>
void StateArchive::field(T& x) {
  if (!ok()) return;
  if constexpr (std::is_same_v<T, bool>) {
    std::uint8_t b = x ? 1 : 0;
    raw(&b, 1);
    if (reading_ && b > 1) fail("a flag holds " + std::to_string(b));
    x = b == 1;
  } else if constexpr (kPlain<T>) {
    raw(&x, sizeof(T));
  } else if constexpr (requires { T::RowsAtCompileTime; }) {
    static_assert(T::SizeAtCompileTime > 0, "fixed-size Eigen matrices only");
    raw(x.data(), sizeof(typename T::Scalar) * T::SizeAtCompileTime);
  } else if constexpr (std::is_same_v<T, Eigen::Isometry3d>) {
    field(x.matrix());
  } else if constexpr (std::is_same_v<T, Eigen::Quaterniond>) {
    field(x.coeffs());
  } else if constexpr (IsSequence<T>::value || std::is_same_v<T, std::string>) {
    sequence(x);
  } else if constexpr (requires {
                         x.has_value();
                         x.emplace();
                       }) {
    bool has = x.has_value();
    field(has);
    if (reading_) x.reset();
    if (has && reading_) x.emplace();
    if (has) field(*x);
  } else if constexpr (requires { x.first, x.second; }) {
    field(x.first);
    field(x.second);
  } else if constexpr (requires { x.describe(*this); }) {
    x.describe(*this);
  } else {
    describe(*this, x);
  }
}

/// CRC-32 (IEEE 802.3, as zlib's crc32) of `bytes`.
std::uint32_t crc32(std::span<const std::uint8_t> bytes);

}  // namespace imufusion

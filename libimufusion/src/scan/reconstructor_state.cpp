// Reconstructor::save and load: the scan as one file, to continue it later.
//
// Layout: "IMUFSCAN" (8 bytes), format version (uint32), CRC-32 of the payload (uint32), payload
// size (uint64), then the payload written by StateArchive (core/state_archive.hpp): the
// configuration, the pyramid level tracking ran at, the host state in the order
// Impl::describe_state() lists it, and the volume's occupied hash slots and stored blocks. The
// model raycast the next frame aligns to is not stored: it is raycast again from the volume at
// its pose, which gives the same maps (a raycast reads the volume only).

#include <array>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>

#include "core/state_fields.hpp"
#include "io/atomic_file.hpp"
#include "scan/reconstructor_impl.hpp"

namespace imufusion {
namespace {

constexpr std::array<char, 8> kMagic = {'I', 'M', 'U', 'F', 'S', 'C', 'A', 'N'};
constexpr std::uint32_t kVersion = 18;  // 2: the lens distortion; 3: the reference's reuse;
                                        // 4: relocalization's confirmation of an ambiguous fit;
                                        // 5: ICP's photometric term, the reference's colours;
                                        // 6: the photometric term's pixel step;
                                        // 7: its least intensity noise;
                                        // 8: relocalization's search after a near fit
                                        //    and without the gyroscope;
                                        // 9: the first frame's own maps as the reference,
                                        //    a restart after a loss at the start;
                                        // 10: ICP's steps past its cap;
                                        // 11: the recovery after a relocalization;
                                        // 12: lost frames placed partly without the IMU;
                                        // 13: the fused frames' orientations;
                                        // 14: relocalization's rival residual ratio and
                                        //     the time of a fit awaiting confirmation;
                                        // 15: the residual test's reference;
                                        // 16: relocalization's rival inlier ratio;
                                        // 17: its translation condition limit, the
                                        //     partial frames' turns;
                                        // 18: the condition factor without the gyroscope
constexpr std::size_t kHeaderBytes = 24;

// Floats in each of the reference maps saved with a scan: four per pixel of the tracking level.
std::size_t reference_map_floats(const ReconstructorConfig& config, int tracking_level) {
  const Intrinsics k = config.intrinsics.at_level(tracking_level);
  return static_cast<std::size_t>(k.width) * static_cast<std::size_t>(k.height) * 4;
}

void describe_volume(StateArchive& a, gpu::TsdfVolume::Contents& c) {
  a(c.hash_slots, c.allocated, c.frame_stamp, c.counters, c.slots, c.keys, c.values, c.stamps,
    c.tsdf_weight, c.colors);
}

Error file_error(const std::filesystem::path& path, ErrorCode code, const std::string& what) {
  return make_error(code, path.string() + ": " + what);
}

// Checks the header of a state file and returns its payload.
Result<std::span<const std::uint8_t>> payload_of(const std::filesystem::path& path,
                                                 const std::vector<std::uint8_t>& bytes) {
  auto bad = [&](const std::string& what) {
    return file_error(path, ErrorCode::kParseError, what);
  };
  if (bytes.size() < kHeaderBytes)
    return bad("not a saved scan: " + std::to_string(bytes.size()) + " bytes, shorter than the " +
               std::to_string(kHeaderBytes) + "-byte header");
  if (std::memcmp(bytes.data(), kMagic.data(), kMagic.size()) != 0)
    return bad("not a saved scan (no IMUFSCAN magic)");
  std::uint32_t version = 0, crc = 0;
  std::uint64_t size = 0;
  std::memcpy(&version, bytes.data() + 8, 4);
  std::memcpy(&crc, bytes.data() + 12, 4);
  std::memcpy(&size, bytes.data() + 16, 8);
  if (version != kVersion)
    return file_error(path, ErrorCode::kUnsupported,
                      "saved scan format version " + std::to_string(version) +
                          ", this build reads version " + std::to_string(kVersion));
  const std::size_t have = bytes.size() - kHeaderBytes;
  if (size != have)
    return bad("truncated or extended: the header promises " + std::to_string(size) +
               " bytes of scan, the file holds " + std::to_string(have));
  const std::span<const std::uint8_t> payload(bytes.data() + kHeaderBytes, have);
  if (crc32(payload) != crc) return bad("corrupt: the checksum does not match the content");
  return payload;
}

}  // namespace

void Reconstructor::Impl::describe_state(StateArchive& a) {
  Impl& m = *this;
  a(m.trajectory, m.T_world_reference, m.has_reference, m.reference_is_frame, m.reference_age,
    m.fused_frames, m.lost_run, m.seed_gate_holding, m.frame_interval, m.tracked_run, m.machine,
    m.pairing, m.prediction_calibration, m.relocalization, m.recovery, m.photometric_sigma);
  bool inertial = m.navigator.has_value();
  a(inertial);
  if (inertial != m.navigator.has_value()) {
    a.fail("the IMU state does not match imu.enabled");
    return;
  }
  if (inertial) a(*m.navigator);
}

// The reference maps saved with a scan, at the tracking level, back on the GPU with the coarser
// levels built from them.
Status Reconstructor::Impl::restore_reference(const std::vector<float>& vertices,
                                              const std::vector<float>& normals,
                                              const std::vector<std::uint32_t>& colors) {
  IMUFUSION_RETURN_IF_ERROR(model.vertices.upload(std::span<const float>(vertices)));
  IMUFUSION_RETURN_IF_ERROR(model.normals.upload(std::span<const float>(normals)));
  reference_has_color = !colors.empty();
  if (reference_has_color)
    IMUFUSION_RETURN_IF_ERROR(model.colors.upload(std::span<const std::uint32_t>(colors)));
  IMUFUSION_RETURN_IF_ERROR(fuse_seq.begin());
  reference.record_maps_from(fuse_seq, model.vertices, model.normals, tracking_level);
  auto t = fuse_seq.submit_and_wait();
  if (!t) return t.error();
  return {};
}

Status Reconstructor::save(const std::filesystem::path& path) const {
  // A writing archive only reads what describe() lists.
  Impl& m = const_cast<Impl&>(*impl_);
  auto volume = m.volume.contents();
  if (!volume) return file_error(path, volume.error().code, volume.error().message);
  StateArchive a = StateArchive::writer();
  ReconstructorConfig config = m.config;
  int level = m.tracking_level, reference_frames = m.reference_frames;
  a(config, level, reference_frames);
  m.describe_state(a);
  describe_volume(a, *volume);
  // The reference maps as raycast (a reference kept over frames was raycast from an older model).
  std::vector<float> vertices, normals;
  std::vector<std::uint32_t> colors;  // RGBA8; empty when the raycast's colours are not kept
  if (m.has_reference) {
    const std::size_t floats = reference_map_floats(m.config, m.tracking_level);
    auto v = m.model.vertices.download_as<float>(floats);
    if (!v) return file_error(path, v.error().code, v.error().message);
    auto n = m.model.normals.download_as<float>(floats);
    if (!n) return file_error(path, n.error().code, n.error().message);
    vertices = std::move(*v);
    normals = std::move(*n);
    if (m.reference_has_color) {
      auto c = m.model.colors.download_as<std::uint32_t>(floats / 4);
      if (!c) return file_error(path, c.error().code, c.error().message);
      colors = std::move(*c);
    }
  }
  a(vertices, normals, colors);
  const std::vector<std::uint8_t>& payload = a.bytes();
  const std::uint32_t crc = crc32(payload);
  const std::uint64_t size = payload.size();
  return io::write_file_atomically(path, [&](std::FILE* f) -> Status {
    const bool written = std::fwrite(kMagic.data(), 1, kMagic.size(), f) == kMagic.size() &&
                         std::fwrite(&kVersion, 4, 1, f) == 1 && std::fwrite(&crc, 4, 1, f) == 1 &&
                         std::fwrite(&size, 8, 1, f) == 1 &&
                         std::fwrite(payload.data(), 1, payload.size(), f) == payload.size();
    if (!written) return file_error(path, ErrorCode::kIoError, "cannot write the saved scan");
    return {};
  });
}

Result<Reconstructor> Reconstructor::load(const std::filesystem::path& path,
                                          const DeviceOptions& device) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes) return bytes.error();
  auto payload = payload_of(path, *bytes);
  if (!payload) return payload.error();
  StateArchive a = StateArchive::reader(*payload);
  ReconstructorConfig config;
  int level = 0, reference_frames = 0;
  a(config, level, reference_frames);
  if (!a.ok()) return file_error(path, ErrorCode::kParseError, a.error());
  config.device = device;
  if (Status valid = config.validate(); !valid.ok())
    return file_error(path, ErrorCode::kParseError,
                      "saved configuration: " + valid.error().message);
  auto created = create(config);
  if (!created) return file_error(path, created.error().code, created.error().message);
  Impl& m = *created->impl_;
  m.tracking_level = level;
  m.reference_frames = reference_frames;
  gpu::TsdfVolume::Contents volume;
  m.describe_state(a);
  describe_volume(a, volume);
  std::vector<float> vertices, normals;
  std::vector<std::uint32_t> colors;
  a(vertices, normals, colors);
  if (a.ok() && a.offset() != payload->size())
    a.fail(std::to_string(payload->size() - a.offset()) + " bytes left over after the volume");
  if (!a.ok()) return file_error(path, ErrorCode::kParseError, a.error());
  if (level < 0 || level >= config.preprocess.levels)
    return file_error(path, ErrorCode::kParseError,
                      "tracking level " + std::to_string(level) + " outside the pyramid");
  if (reference_frames < 1)
    return file_error(path, ErrorCode::kParseError,
                      "reference frames " + std::to_string(reference_frames) + " below 1");
  const Intrinsics k = config.intrinsics.at_level(level);
  const std::size_t floats = reference_map_floats(config, level);
  if (m.has_reference && (vertices.size() != floats || normals.size() != floats))
    return file_error(path, ErrorCode::kParseError,
                      "the reference maps hold " + std::to_string(vertices.size()) + " and " +
                          std::to_string(normals.size()) + " floats, the tracking level's " +
                          std::to_string(k.width) + "x" + std::to_string(k.height) + " needs " +
                          std::to_string(floats));
  if (!colors.empty() && colors.size() != floats / 4)
    return file_error(path, ErrorCode::kParseError,
                      "the reference colours hold " + std::to_string(colors.size()) +
                          " pixels, the tracking level has " + std::to_string(floats / 4));
  if (Status restored = m.volume.restore(volume); !restored.ok())
    return file_error(path, restored.error().code, restored.error().message);
  if (m.has_reference) {
    if (Status s = m.restore_reference(vertices, normals, colors); !s.ok())
      return file_error(path, s.error().code, s.error().message);
  }
  return created;
}

}  // namespace imufusion

#pragma once
// Writes OpenNI2 .oni recordings from synthetic frames, for tests that play them back through
// OpenNI2's own file device (the OniFile driver). No camera can feed openni::Recorder here, so
// the records are laid out exactly as openni::Recorder lays them out and as the OniFile player
// parses them (file format 1.0.1.0, 64-bit positions, little-endian, packed):
//
//   file header   "NI10", version {major 1, minor 0, maintenance 1, build 0} (u8 u8 u16 u32),
//                 max timestamp (u64, us), max node id (u32)
//   record        header: magic "NIR\0" (u32), type (u32), node id (u32), fields size (u32, the
//                 header's 28 bytes included), payload size (u32), undo position (u64); then
//                 the fields, then the payload
//   per stream    NODE_ADDED (name, node type, codec, frame count, min/max timestamp, seek-table
//                 position), its properties (xnMapOutputMode, oniPixelFormat, xnFOV, ...),
//                 NODE_STATE_READY
//   then          NODE_DATA_BEGIN per stream, the NEW_DATA records of all streams in timestamp
//                 order (timestamp in us, 1-based frame number, the raw frame as payload: codec
//                 "NONE"), then per stream NODE_REMOVED and its SEEK_TABLE (one 20-byte entry per
//                 frame after an empty entry 0), and END.
//
// The player refuses a frame number beyond the node's frame count, a timestamp beyond the
// header's maximum and an undo chain that does not lead back to earlier records of the node, so
// those are filled in exactly.

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "imufusion/result.hpp"

namespace imufusion::test {

/// One frame of an .oni stream: its device timestamp (microseconds) and its pixels, row-major
/// without padding (depth: uint16 little-endian per pixel; colour: RGB888).
struct OniFrame {
  std::uint64_t timestamp_us = 0;
  std::vector<std::uint8_t> pixels;
};

/// A recording: one depth stream (1 mm units) and optionally a colour stream of the same size.
struct OniRecording {
  int width = 0, height = 0, fps = 30;
  double horizontal_fov = 0.0, vertical_fov = 0.0;  // radians, what the depth stream reports
  int max_depth_mm = 10000;
  std::vector<OniFrame> depth;
  std::vector<OniFrame> color;  // empty: a depth-only recording
  /// False: the file as openni::Recorder leaves it when it is interrupted before it is closed
  /// (frame counts and timestamps unknown in the stream headers, no seek tables, no END).
  bool finalized = true;
};

/// Depth pixels (uint16 per pixel) as the little-endian bytes a NEW_DATA payload carries.
inline std::vector<std::uint8_t> oni_depth_bytes(const std::vector<std::uint16_t>& depth) {
  std::vector<std::uint8_t> bytes(depth.size() * 2);
  for (std::size_t i = 0; i < depth.size(); ++i) {
    bytes[2 * i] = static_cast<std::uint8_t>(depth[i] & 0xff);
    bytes[2 * i + 1] = static_cast<std::uint8_t>(depth[i] >> 8);
  }
  return bytes;
}

namespace oni_detail {

// Record types and node types of the format (OpenNI2 Source/Core/OniDataRecords.h).
enum : std::uint32_t {
  kIntProperty = 0x03,
  kGeneralProperty = 0x06,
  kNodeRemoved = 0x07,
  kNodeDataBegin = 0x08,
  kNodeStateReady = 0x09,
  kNewData = 0x0A,
  kEnd = 0x0B,
  kNodeAdded = 0x0D,
  kSeekTable = 0x0E,
};
enum : std::uint32_t { kNodeDepth = 2, kNodeImage = 3 };
constexpr std::uint32_t kRecordMagic = 0x0052494E;  // "NIR\0"
constexpr std::uint32_t kRecordHeaderSize = 28;
constexpr std::uint32_t kCodecNone = 'N' | ('O' << 8) | ('N' << 16) | (std::uint32_t('E') << 24);
// OniPixelFormat values (OniCEnums.h) and OpenNI 1 XnPixelFormat values.
constexpr std::uint64_t kOniDepth1mm = 100, kOniRgb888 = 200;
constexpr std::uint64_t kXnRgb24 = 1, kXnGray16 = 4;

class Buffer {
 public:
  std::size_t size() const { return bytes_.size(); }
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }
  void u8(std::uint8_t v) { bytes_.push_back(v); }
  void u16(std::uint16_t v) { le(v, 2); }
  void u32(std::uint32_t v) { le(v, 4); }
  void u64(std::uint64_t v) { le(v, 8); }
  void f64(double v) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    u64(bits);
  }
  void raw(const void* data, std::size_t size) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    bytes_.insert(bytes_.end(), p, p + size);
  }
  // A length-prefixed string: u32 length including the terminating NUL, then the bytes.
  void string(std::string_view s) {
    u32(static_cast<std::uint32_t>(s.size() + 1));
    raw(s.data(), s.size());
    u8(0);
  }
  void patch_u32(std::size_t at, std::uint32_t v) { patch(at, v, 4); }
  void patch_u64(std::size_t at, std::uint64_t v) { patch(at, v, 8); }

 private:
  void le(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) bytes_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void patch(std::size_t at, std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) bytes_[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
  }
  std::vector<std::uint8_t> bytes_;
};

// Writes a record: header, `fields` (after the header), `payload`. Returns its position.
inline std::size_t record(Buffer& out, std::uint32_t type, std::uint32_t node,
                          std::uint64_t undo_position, const Buffer& fields,
                          const std::uint8_t* payload = nullptr, std::size_t payload_size = 0) {
  const std::size_t at = out.size();
  out.u32(kRecordMagic);
  out.u32(type);
  out.u32(node);
  out.u32(kRecordHeaderSize + static_cast<std::uint32_t>(fields.size()));
  out.u32(static_cast<std::uint32_t>(payload_size));
  out.u64(undo_position);
  out.raw(fields.bytes().data(), fields.size());
  if (payload_size > 0) out.raw(payload, payload_size);
  return at;
}

inline void general_property(Buffer& out, std::uint32_t node, std::string_view name,
                             const Buffer& value) {
  Buffer fields;
  fields.string(name);
  fields.u32(static_cast<std::uint32_t>(value.size()));
  fields.raw(value.bytes().data(), value.size());
  record(out, kGeneralProperty, node, 0, fields);
}

inline void int_property(Buffer& out, std::uint32_t node, std::string_view name,
                         std::uint64_t value) {
  Buffer fields;
  fields.string(name);
  fields.u32(8);
  fields.u64(value);
  record(out, kIntProperty, node, 0, fields);
}

struct Stream {
  Stream(std::uint32_t node_id, const std::vector<OniFrame>* stream_frames, bool is_depth)
      : node(node_id), frames(stream_frames), depth(is_depth) {}
  std::uint32_t node;
  const std::vector<OniFrame>* frames;
  bool depth;
  std::size_t node_added_at = 0;
  std::size_t seek_position_field = 0;  // where NODE_ADDED's seek-table position lies
  std::uint64_t last_data_at = 0;       // the previous NEW_DATA of this node (undo chain)
  std::vector<std::uint64_t> data_at;   // each frame's NEW_DATA position
};

// The frames' sizes and strictly increasing stamps of each stream; the latest stamp (us).
inline Result<std::uint64_t> check_streams(const std::filesystem::path& path,
                                           const std::vector<Stream>& streams, std::size_t pixels) {
  std::uint64_t max_timestamp = 0;
  for (const Stream& s : streams) {
    const std::size_t bytes = pixels * (s.depth ? 2 : 3);
    for (std::size_t i = 0; i < s.frames->size(); ++i) {
      const OniFrame& f = (*s.frames)[i];
      if (f.pixels.size() != bytes ||
          (i > 0 && f.timestamp_us <= (*s.frames)[i - 1].timestamp_us)) {
        return make_error(ErrorCode::kInvalidArgument,
                          path.string() + ": frame " + std::to_string(i) + " of the " +
                              (s.depth ? "depth" : "colour") +
                              " stream has the wrong size or a timestamp that does not increase");
      }
      max_timestamp = std::max(max_timestamp, f.timestamp_us);
    }
  }
  return max_timestamp;
}

// What an interrupted recorder leaves in place of the counts it patches in when closed.
constexpr std::uint32_t kUnknownCount = 0xffffffff;
constexpr std::uint64_t kUnknownTime = ~std::uint64_t{0};

inline std::uint32_t frame_count(const Stream& s, bool done) {
  return done ? static_cast<std::uint32_t>(s.frames->size()) : kUnknownCount;
}

// A stream's NODE_ADDED record and its properties, up to NODE_STATE_READY.
inline void write_node(Buffer& out, Stream& s, const OniRecording& recording, bool done) {
  const std::size_t pixels = static_cast<std::size_t>(recording.width) * recording.height;
  Buffer fields;
  fields.string(s.depth ? "Depth" : "Image");
  fields.u32(s.depth ? kNodeDepth : kNodeImage);
  fields.u32(kCodecNone);
  fields.u32(frame_count(s, done));
  fields.u64(done ? s.frames->front().timestamp_us : 0);
  fields.u64(done ? s.frames->back().timestamp_us : kUnknownTime);
  s.seek_position_field = out.size() + kRecordHeaderSize + fields.size();
  fields.u64(0);  // seek-table position, patched once the table is written
  s.node_added_at = record(out, kNodeAdded, s.node, 0, fields);

  int_property(out, s.node, "oniRequiredFrameSize", pixels * (s.depth ? 2 : 3));
  int_property(out, s.node, "xnIsGenerating", 1);
  if (s.depth) int_property(out, s.node, "xnDeviceMaxDepth", recording.max_depth_mm);
  Buffer mode;  // XnMapOutputMode: x resolution, y resolution, fps (u32 each)
  mode.u32(static_cast<std::uint32_t>(recording.width));
  mode.u32(static_cast<std::uint32_t>(recording.height));
  mode.u32(static_cast<std::uint32_t>(recording.fps));
  general_property(out, s.node, "xnMapOutputMode", mode);
  int_property(out, s.node, "xnPixelFormat", s.depth ? kXnGray16 : kXnRgb24);
  int_property(out, s.node, "oniPixelFormat", s.depth ? kOniDepth1mm : kOniRgb888);
  // The player hands out no frame of a stream whose cropping state it does not know.
  int_property(out, s.node, "Cropping", 1);
  Buffer cropping;  // XnCropping: enabled (u32), x offset, y offset, width, height (u16 each)
  cropping.u32(0);
  cropping.u16(0);
  cropping.u16(0);
  cropping.u16(static_cast<std::uint16_t>(recording.width));
  cropping.u16(static_cast<std::uint16_t>(recording.height));
  general_property(out, s.node, "xnCropping", cropping);
  if (s.depth) {
    Buffer fov;  // XnFieldOfView: horizontal, vertical (radians, f64 each)
    fov.f64(recording.horizontal_fov);
    fov.f64(recording.vertical_fov);
    general_property(out, s.node, "xnFOV", fov);
  }
  record(out, kNodeStateReady, s.node, 0, Buffer());
}

// Frames of all streams in timestamp order, depth first on equal stamps.
inline void write_frames(Buffer& out, std::vector<Stream>& streams) {
  std::vector<std::size_t> next(streams.size(), 0);
  while (true) {
    int pick = -1;
    for (std::size_t k = 0; k < streams.size(); ++k) {
      if (next[k] >= streams[k].frames->size()) continue;
      if (pick < 0 || (*streams[k].frames)[next[k]].timestamp_us <
                          (*streams[pick].frames)[next[pick]].timestamp_us) {
        pick = static_cast<int>(k);
      }
    }
    if (pick < 0) break;
    Stream& s = streams[pick];
    const OniFrame& f = (*s.frames)[next[pick]];
    Buffer fields;
    fields.u64(f.timestamp_us);
    fields.u32(static_cast<std::uint32_t>(++next[pick]));  // frame numbers start at 1
    const std::size_t at =
        record(out, kNewData, s.node, s.last_data_at, fields, f.pixels.data(), f.pixels.size());
    s.last_data_at = at;
    s.data_at.push_back(at);
  }
}

// A closed recording's NODE_REMOVED and seek table per stream.
inline void write_seek_tables(Buffer& out, std::vector<Stream>& streams) {
  for (Stream& s : streams) {
    record(out, kNodeRemoved, s.node, s.node_added_at, Buffer());
    Buffer table;  // entry 0 is empty; then timestamp (u64), configuration (u32), position (u64)
    table.u64(0);
    table.u32(0);
    table.u64(0);
    for (std::size_t i = 0; i < s.frames->size(); ++i) {
      table.u64((*s.frames)[i].timestamp_us);
      table.u32(0);
      table.u64(s.data_at[i]);
    }
    const std::size_t table_at =
        record(out, kSeekTable, s.node, 0, Buffer(), table.bytes().data(), table.size());
    out.patch_u64(s.seek_position_field, table_at);
  }
}

}  // namespace oni_detail

/// Writes `recording` to `path`. kInvalidArgument when a frame's size or the timestamps do not
/// make a valid recording (sizes must match the resolution, timestamps increase strictly).
inline Status write_oni(const std::filesystem::path& path, const OniRecording& recording) {
  using namespace oni_detail;
  const std::size_t pixels = static_cast<std::size_t>(recording.width) * recording.height;
  std::vector<Stream> streams;
  streams.push_back(Stream{1, &recording.depth, true});
  if (!recording.color.empty()) streams.push_back(Stream{2, &recording.color, false});
  const Result<std::uint64_t> max_timestamp = check_streams(path, streams, pixels);
  if (!max_timestamp) return max_timestamp.error();
  if (recording.depth.empty()) {
    return make_error(ErrorCode::kInvalidArgument, path.string() + ": no depth frame to write");
  }
  const bool done = recording.finalized;

  Buffer out;
  out.raw("NI10", 4);
  out.u8(1);   // major
  out.u8(0);   // minor
  out.u16(1);  // maintenance: 1.0.1.0 is the first version with 64-bit positions
  out.u32(0);  // build
  out.u64(done ? *max_timestamp : kUnknownTime);
  out.u32(static_cast<std::uint32_t>(streams.size()));  // max node id
  for (Stream& s : streams) write_node(out, s, recording, done);
  for (const Stream& s : streams) {
    Buffer fields;
    fields.u32(frame_count(s, done));
    fields.u64(done ? s.frames->back().timestamp_us : kUnknownTime);
    record(out, kNodeDataBegin, s.node, 0, fields);
  }
  write_frames(out, streams);
  if (done) {
    write_seek_tables(out, streams);
    record(out, kEnd, 0, 0, Buffer());
  }

  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(reinterpret_cast<const char*>(out.bytes().data()),
             static_cast<std::streamsize>(out.size()));
  if (!file) return make_error(ErrorCode::kIoError, path.string() + ": cannot write");
  return {};
}

}  // namespace imufusion::test

#pragma once
// Atomic replacement of a file: the content goes to `PATH.tmp-PID-XXXXXXXX` in the same
// directory and is renamed over PATH only when complete, so a reader never sees a half-written
// file under the final name and a failed write leaves an existing file untouched. (Durability
// across a power loss is not promised: there is no fsync.) A temporary left by a killed writer
// is removed by the next process that writes into its directory. Reading takes regular files
// only, up to a size limit, so a FIFO cannot block a reader nor a device exhaust its memory.

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "imufusion/result.hpp"

namespace imufusion::io {

/// The largest file read_file_bytes reads by default (bytes): 2 GiB.
inline constexpr std::uint64_t kMaxFileBytes = std::uint64_t{2} << 30;

/// Opens a fresh temporary file next to `path`, lets `write` fill it through the FILE*, closes it
/// and renames it over `path`. On any failure the temporary file is removed and the error names
/// `path`. `write` must not close the stream.
Status write_file_atomically(const std::filesystem::path& path,
                             const std::function<Status(std::FILE*)>& write);

/// Writes `content` to `path` atomically.
Status write_text_atomically(const std::filesystem::path& path, std::string_view content);

/// Removes the temporaries of atomic writes into `directory` whose writer is no longer running
/// (write_file_atomically does this on its first write into a directory); returns how many.
std::size_t remove_stale_temporaries(const std::filesystem::path& directory);

/// Reads a whole regular file of at most `max_bytes`. kNotFound when it does not exist,
/// kInvalidArgument when it is a FIFO, device or socket or is larger, kIoError when it is a
/// directory or cannot be read.
Result<std::vector<std::uint8_t>> read_file_bytes(const std::filesystem::path& path,
                                                  std::uint64_t max_bytes = kMaxFileBytes);

}  // namespace imufusion::io

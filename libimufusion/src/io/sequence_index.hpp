#pragma once
// Loading and checking the text side of a sequence (FORMAT.md), collecting every problem rather
// than stopping at the first: SequenceReader::open reports the first, imufusion-info all of them.

#include <filesystem>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/sequence.hpp"

namespace imufusion::io {

struct SequenceIndex {
  SequenceInfo info;
  /// Every problem found, in file order; each message names the file (and line).
  std::vector<Error> problems;
};

/// Reads every text file of the sequence in `directory`, checks each line, checks that every
/// listed image exists, reads the first depth PNG's header for the image size and pairs colour
/// frames with depth frames. Loads no image.
SequenceIndex load_sequence_index(const std::filesystem::path& directory,
                                  const SequenceOptions& options);

/// One-to-one pairing of `color` stamps with `depth` stamps, closest pairs first, for stamps
/// differing by less than `max_difference` seconds (TUM associate.py). Both inputs ascending.
/// Returns, for each depth stamp, the index of its colour stamp or -1.
std::vector<int> associate_streams(const std::vector<double>& depth,
                                   const std::vector<double>& color, double max_difference);

}  // namespace imufusion::io

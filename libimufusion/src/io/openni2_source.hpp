#pragma once
// OpenNI2 cameras and .oni recordings as a FrameSource (source.hpp). Compiled with OpenNI2 when
// the build found it (IMUFUSION_HAVE_OPENNI2), else every open fails with kUnsupported.

#include <memory>
#include <string_view>

#include "imufusion/source.hpp"

namespace imufusion::io {

/// `uri`: a device URI, empty for the first device. `is_file`: `uri` is a .oni path.
Result<std::unique_ptr<FrameSource>> open_openni2_source(std::string_view uri, bool is_file,
                                                         const SourceOptions& options);

}  // namespace imufusion::io

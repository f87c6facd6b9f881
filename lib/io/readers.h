// The format parsers behind ReadMeshFile, on a file's contents in memory
// (the fuzz targets call them directly). `path` only names the file in
// messages. Each returns InvalidArgument naming the line (text) or byte
// offset (binary) and what was wrong; none allocates from a declared count
// that the remaining bytes cannot hold, none opens another file, none
// prints.
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lib/io/mesh_file.h"

namespace meshgauge::io {

// A face record may list this many corners before the reader stops reading
// it (the builder then rejects the face).
inline constexpr int64_t kMaxCornersPerRecord = 4096;

absl::StatusOr<MeshFile> ParseObj(absl::string_view text,
                                  const std::string& path,
                                  const ReadLimits& limits = {});
absl::StatusOr<MeshFile> ParseOff(absl::string_view text,
                                  const std::string& path,
                                  const ReadLimits& limits = {});
absl::StatusOr<MeshFile> ParsePly(absl::string_view data,
                                  const std::string& path,
                                  const ReadLimits& limits = {});
absl::StatusOr<MeshFile> ParseStl(absl::string_view data,
                                  const std::string& path,
                                  const ReadLimits& limits = {});

}  // namespace meshgauge::io

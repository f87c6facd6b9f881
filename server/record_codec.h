// Byte encodings of a SessionRecord's parts for an external store: fixed
// little-endian layouts, positions as raw float64 (exact). Decoding checks
// every length: corrupt bytes are DATA_LOSS, never a crash.
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/session_records.h"

namespace meshgauge::server {

std::string EncodeInfo(const wire::SessionInfo& info);
absl::Status DecodeInfo(const std::string& bytes, wire::SessionInfo* info);

// Faces, regions and region directions (everything of a mesh but positions).
std::string EncodeTopology(const Mesh& mesh);
absl::Status DecodeTopology(const std::string& bytes, Mesh* mesh);

std::string EncodePositions(const std::vector<Vec3>& positions);
absl::StatusOr<std::vector<Vec3>> DecodePositions(const std::string& bytes,
                                                  int64_t expected_count);

}  // namespace meshgauge::server

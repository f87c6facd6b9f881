// Conversions between a SessionRecord's parts and their stored bytes: the
// session's facts as a public v1::SessionInfo (through the wire layer), the
// rest as the private messages of session_record.proto. Positions are float64
// (exact). Decoding checks everything a replica relies on (dimension, counts,
// face arity, indices in range): corrupt bytes are DATA_LOSS, never a crash.
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/session_records.h"

namespace meshgauge::server {

// The stored records' format, part of every key: raise it for a change of
// session_record.proto that an older replica would misread.
inline constexpr int kRecordFormat = 2;

// The facts of a session fixed at its creation: dimension, counts, memory,
// signed volume, closedness and warnings (the id, generation, idle time and
// BVH counts are the store's to keep apart, and are not stored).
std::string EncodeInfo(const wire::SessionInfo& info);
absl::StatusOr<wire::SessionInfo> DecodeInfo(const std::string& bytes);

// Faces, regions and region directions (everything of a mesh but positions).
std::string EncodeTopology(const Mesh& mesh);
// Precondition for `num_vertices`: the vertex count the faces index into.
absl::Status DecodeTopology(const std::string& bytes, int64_t num_vertices,
                            Mesh* mesh);

std::string EncodePositions(const std::vector<Vec3>& positions);
absl::StatusOr<std::vector<Vec3>> DecodePositions(const std::string& bytes,
                                                  int64_t expected_count);

}  // namespace meshgauge::server

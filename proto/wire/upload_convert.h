// The CreateSession stream of a mesh (header, chunks, footer) and its
// checksum, part of the conversion layer of convert.h: the client writes
// the stream with WriteUpload, the server checks it with the same UploadCrc.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "lib/core/mesh.h"
#include "meshgauge/v1/meshgauge.pb.h"

namespace meshgauge::wire {

// CRC-32 (zlib) of an upload as the Footer defines it: all positions as
// float64, then all face sizes, indices and regions as int32, little-endian,
// each stream in the order of the chunks; a file upload's is over its bytes.
class UploadCrc {
 public:
  // The chunk's arrays, appended to their streams.
  void Add(const v1::CreateSessionRequest::Chunk& chunk);
  // A file upload's next bytes.
  void AddFile(std::string_view bytes);
  uint32_t Value() const;

 private:
  unsigned long crc_[4] = {0, 0, 0, 0};  // positions, sizes, indices, regions.
  int64_t bytes_[4] = {0, 0, 0, 0};
};

// Calls `write` with every message of the upload of `mesh` as session
// `session_id`, in order: the header (counts, region directions), chunks of
// at most `per_chunk` (>= 1) vertices and faces, and the footer with
// UploadCrc's value. Stops at the first message `write` refuses; returns
// whether all were written.
bool WriteUpload(
    const Mesh& mesh, const std::string& session_id, int64_t per_chunk,
    const std::function<bool(const v1::CreateSessionRequest&)>& write);

}  // namespace meshgauge::wire

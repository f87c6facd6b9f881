// Assembles a CreateSession stream (header, chunks, footer) into a mesh,
// checking it as it arrives: declared counts (a chunk is refused whole,
// before anything of it is stored, when its arrays or file bytes exceed
// them) and server limits, then the final counts and CRC-32. Arrays are
// made into faces, and files read, by lib/io's builder and readers.
#pragma once

#include <grpcpp/support/byte_buffer.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "lib/core/mesh_repair.h"
#include "lib/io/mesh_file.h"
#include "meshgauge/v1/meshgauge.pb.h"
#include "proto/wire/upload_convert.h"
#include "server/server_options.h"

namespace meshgauge::server {

// One CreateSession message as the server reads it, checked before it is
// parsed: a parsed message takes more memory than its bytes (a packed
// varint 4 bytes per byte; an empty sub-message, 2 bytes on the wire, a
// heap object), so its size is checked against `limit` and a header's
// against kMaxUploadHeaderBytes (a header holds an id and region
// directions; chunks hold packed arrays only). A refused message is not
// parsed.
struct UploadMessage {
  explicit UploadMessage(int64_t limit) : limit(limit) {}
  const int64_t limit;
  int64_t received_bytes = 0;
  std::string refused;  // why it was not parsed; empty: `request` holds it.
  v1::CreateSessionRequest request;
};

// Bytes reserved per declared file byte before a file upload's data: the
// file and a start for the reader, which reserves more as it needs it.
inline constexpr int64_t kFileReadFactor = 8;

// The largest file upload: --max_upload_file_bytes, and what the tenant's
// budget can reserve (GetServerInfo reports it).
inline int64_t MaxUploadFileBytes(const ServerOptions& options) {
  return std::min(options.max_upload_file_bytes,
                  options.BudgetPerTenant() / kFileReadFactor);
}

// The polygon fallback work (corners³ summed, about 1 ns each) an upload
// may cost: about 4 s.
inline constexpr int64_t kMaxUploadFallbackWork = int64_t{1} << 32;

// Largest header of an upload: 1 MiB, some 130,000 region directions.
inline constexpr int64_t kMaxUploadHeaderBytes = int64_t{1} << 20;

class MeshAssembler {
 public:
  explicit MeshAssembler(const ServerOptions& options) : options_(options) {}

  // Every error is INVALID_ARGUMENT (or RESOURCE_EXHAUSTED for a limit) with
  // a message naming the field.
  absl::Status Add(const v1::CreateSessionRequest& request);
  // The stream ended: returns the mesh as the readers return a file's (not
  // validated: polygons triangulated, region directions set), or the defect
  // (a stream without footer is "truncated"). It is built within `limits`
  // (the server's max_vertices and max_faces, the memory it may reserve).
  absl::StatusOr<io::MeshFile> Finish(const io::ReadLimits& limits);
  const std::string& session_id() const { return session_id_; }
  // After the header: true when the upload sends a file.
  bool file_upload() const { return !file_format_.empty(); }
  // The repairs the header asks for.
  RepairOptions repairs() const { return repairs_; }
  // After the header: the bytes to reserve before the data (arrays: the
  // session they make; a file: kFileReadFactor per byte).
  int64_t EstimatedBytes() const;
  // Bytes that arrived and are held (the arrays, the file's bytes), with
  // the mesh the arrays will make.
  int64_t bytes_held() const;

 private:
  absl::Status Header(const v1::CreateSessionRequest::Header& h);
  absl::Status FileHeader(const v1::CreateSessionRequest::Header& h);
  absl::Status Chunk(const v1::CreateSessionRequest::Chunk& c);
  absl::Status FileChunk(const v1::CreateSessionRequest::Chunk& c);
  // INVALID_ARGUMENT when a chunk's arrays hold more than the header's
  // counts leave room for (checked before anything is stored).
  absl::Status CheckRoom(const v1::CreateSessionRequest::Chunk& c) const;
  absl::Status Footer(const v1::CreateSessionRequest::Footer& f);
  absl::StatusOr<io::MeshFile> FinishArrays(const io::ReadLimits& limits);
  absl::StatusOr<io::MeshFile> FinishFile(const io::ReadLimits& limits);
  // INVALID_ARGUMENT unless the checksum over what arrived, in the footer's
  // order, is the footer's.
  absl::Status CheckCrc() const;

  const ServerOptions& options_;
  bool have_header_ = false, have_footer_ = false;
  std::string session_id_;
  int dimension_ = 0;
  std::map<int32_t, ConeDirection> region_directions_;
  RepairOptions repairs_;
  int64_t declared_vertices_ = 0, declared_faces_ = 0, declared_indices_ = 0;
  std::vector<double> coords_;
  std::vector<int32_t> sizes_, indices_, regions_;
  // A file upload: its format (".obj", ...), declared size and bytes.
  std::string file_format_, file_name_;
  int64_t declared_file_bytes_ = 0;
  std::string file_;
  wire::UploadCrc crc_;  // of what the chunks carried.
  uint32_t footer_crc_ = 0;
};

// Reads one CreateSession message of `buffer` into `msg` (consuming the
// buffer): `refused` says why when it is over msg->limit or its header over
// kMaxUploadHeaderBytes (then nothing is parsed). False when the bytes are
// not a CreateSessionRequest.
bool ParseUploadMessage(grpc::ByteBuffer* buffer, UploadMessage* msg);

}  // namespace meshgauge::server

// Assembles a CreateSession stream (header, chunks, footer) into a Mesh,
// checking it as it arrives: declared counts (a chunk is refused whole,
// before anything of it is stored, when its arrays exceed them) and server
// limits, face sizes
// against indices, the final counts and CRC-32, then SPEC §1 validation.
#pragma once

#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/config.h>
#include <grpcpp/impl/codegen/serialization_traits.h>
#include <grpcpp/support/status.h>
#include <zlib.h>

#include <string>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "meshgauge/v1/meshgauge.pb.h"
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

// Largest header of an upload: 1 MiB, some 130,000 region directions.
inline constexpr int64_t kMaxUploadHeaderBytes = int64_t{1} << 20;

class MeshAssembler {
 public:
  explicit MeshAssembler(const ServerOptions& options) : options_(options) {}

  // Every error is INVALID_ARGUMENT (or RESOURCE_EXHAUSTED for a limit) with
  // a message naming the field.
  absl::Status Add(const v1::CreateSessionRequest& request);
  // The stream ended: returns the validated mesh, or the defect (a stream
  // without footer is "truncated").
  absl::StatusOr<Mesh> Finish();
  const std::string& session_id() const { return session_id_; }
  // After the header: its declared counts.
  int dimension() const { return mesh_.dimension; }
  int64_t declared_vertices() const { return declared_vertices_; }
  int64_t declared_faces() const { return declared_faces_; }
  // Bytes buffered so far (the arrays' capacities).
  int64_t bytes_held() const;

 private:
  absl::Status Header(const v1::CreateSessionRequest::Header& h);
  absl::Status Chunk(const v1::CreateSessionRequest::Chunk& c);
  // INVALID_ARGUMENT when a chunk's arrays hold more than the header's
  // counts leave room for (checked before anything is stored).
  absl::Status CheckRoom(const v1::CreateSessionRequest::Chunk& c) const;
  absl::Status Footer(const v1::CreateSessionRequest::Footer& f);

  const ServerOptions& options_;
  bool have_header_ = false, have_footer_ = false;
  std::string session_id_;
  Mesh mesh_;
  int64_t declared_vertices_ = 0, declared_faces_ = 0;
  std::vector<double> coords_;          // pending coordinates (partial vertex).
  std::vector<int32_t> pending_sizes_;  // faces waiting for indices.
  std::vector<int32_t> pending_indices_;
  // CRC over positions, sizes, indices, regions (in that order): the four
  // streams are checksummed separately and combined at the end.
  uLong crc_[4] = {0, 0, 0, 0};
  int64_t crc_len_[4] = {0, 0, 0, 0};
  uint32_t footer_crc_ = 0;
};

}  // namespace meshgauge::server

// The server reads CreateSession as UploadMessage (see service.cc).
template <>
class grpc::SerializationTraits<meshgauge::server::UploadMessage, void> {
 public:
  static grpc::Status Deserialize(grpc::ByteBuffer* buffer,
                                  meshgauge::server::UploadMessage* msg);
  // Never sent; present for the handler's template.
  static grpc::Status Serialize(const meshgauge::server::UploadMessage&,
                                grpc::ByteBuffer*, bool*);
};

// What the server's replies take on the wire, estimated before they are
// computed or written, and how the ComputeSdf stream is cut into messages:
// the byte counts of the encoding belong to the conversion layer (convert.h).
#pragma once

#include <cstdint>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "lib/core/sensitivity.h"
#include "meshgauge/v1/meshgauge.pb.h"

namespace meshgauge::wire {

// Bytes of a reply holding `doubles` packed doubles plus a small envelope.
int64_t PackedReplyBytes(int64_t doubles);
// A ComputeVjpResponse: the gradient, `dimension` doubles per vertex, and
// with `with_tails` (a range's reply) the partial sums' tails, estimated.
int64_t VjpReplyBytes(const Mesh& mesh, bool with_tails = false);
// A ComputePenaltyResponse: the gradient when `with_gradient` (with
// `range_part`: as a ranged VJP's, with its tails, and the measure part),
// and up to `thin_regions` thin regions (0: no thin-surface request).
int64_t PenaltyReplyBytes(const Mesh& mesh, bool with_gradient,
                          int64_t thin_regions, bool range_part = false);
// A GetMeshResponse of `mesh`.
int64_t MeshReplyBytes(const Mesh& mesh);

// RESOURCE_EXHAUSTED, naming --max_message_bytes, when a reply of `bytes`
// exceeds `max_message_bytes` (checked before computing it).
absl::Status CheckReplyBytes(int64_t bytes, int64_t max_message_bytes);

// RESOURCE_EXHAUSTED, naming --max_message_bytes, when the GradCheck
// message `msg` (written) exceeds `max_message_bytes`.
absl::Status CheckGradCheckBytes(const v1::GradCheckResponse& msg,
                                 int64_t max_message_bytes);

// ComputeSdfRequest.chunk_vertices: 0 is kDefaultChunkVertices.
inline constexpr int kDefaultChunkVertices = 16384;
inline constexpr int kMaxChunkVertices = 65536;
// The samples per chunk a request asks for. Errors: INVALID_ARGUMENT
// outside [1, kMaxChunkVertices] (0 aside).
absl::StatusOr<int> ChunkSamplesFromWire(int chunk_vertices);

// Cuts a ComputeSdf result of `samples` samples (with the Jacobian's rows
// when `jacobian` is given, `dimension` doubles per entry) into chunks of
// at most `chunk` samples whose messages stay within half of
// `max_message_bytes`.
class SdfChunker {
 public:
  SdfChunker(const SparseJacobian* jacobian, int dimension, int64_t samples,
             int chunk, int64_t max_message_bytes);
  // RESOURCE_EXHAUSTED when one sample's Jacobian row cannot fit in a
  // message (a message holds at least one sample).
  absl::Status CheckRows() const;
  // The end of the chunk starting at `begin` (< samples).
  int64_t ChunkEnd(int64_t begin) const;

 private:
  // About 30 bytes of values per sample; 4 + 8 x dimension per Jacobian
  // entry.
  int64_t SampleBytes(int64_t p) const;

  const SparseJacobian* jacobian_;
  int dimension_;
  int64_t samples_;
  int chunk_;
  int64_t max_message_bytes_;
  int64_t budget_;
};

}  // namespace meshgauge::wire

#include "proto/wire/reply_bytes.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace meshgauge::wire {

int64_t PackedReplyBytes(int64_t doubles) { return doubles * 8 + 256; }

int64_t VjpReplyBytes(const Mesh& mesh, bool with_tails) {
  const int64_t values = mesh.num_vertices() * mesh.dimension;
  // A tail: its count (a byte) and, for a sum of many terms, about two
  // doubles (their exact sum spans some 100 to 150 bits).
  return with_tails ? PackedReplyBytes(3 * values) + values
                    : PackedReplyBytes(values);
}

int64_t PenaltyReplyBytes(const Mesh& mesh, bool with_gradient,
                          int64_t thin_regions, bool range_part) {
  // A thin region is about 18 doubles on the wire (four points, five
  // scalars and their tags).
  constexpr int64_t kThinRegionDoubles = 18;
  const int64_t thin = PackedReplyBytes(thin_regions * kThinRegionDoubles);
  if (!with_gradient) return thin;
  if (!range_part) return thin + VjpReplyBytes(mesh);
  // The VJP's part with its tails, and the measure part.
  return thin + VjpReplyBytes(mesh, /*with_tails=*/true) +
         PackedReplyBytes(mesh.num_vertices() * mesh.dimension);
}

int64_t MeshReplyBytes(const Mesh& mesh) {
  // Coordinates as doubles (8 bytes); varints of at most 1 byte per size,
  // 5 per index and 10 per (possibly negative) region.
  return PackedReplyBytes(
      mesh.num_vertices() * mesh.dimension +
      (mesh.num_faces() * (1 + 4 * 5) + std::ssize(mesh.face_regions) * 10) /
          8);
}

absl::Status CheckReplyBytes(int64_t bytes, int64_t max_message_bytes) {
  if (bytes <= max_message_bytes) return absl::OkStatus();
  return absl::ResourceExhaustedError(
      absl::StrCat("the reply would be about ", bytes,
                   " bytes, over the server's limit of ", max_message_bytes,
                   " bytes (--max_message_bytes); refused "
                   "before computing"));
}

absl::Status CheckGradCheckBytes(const v1::GradCheckResponse& msg,
                                 int64_t max_message_bytes) {
  const int64_t bytes = static_cast<int64_t>(msg.ByteSizeLong());
  if (bytes <= max_message_bytes) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrCat(
      "the report of ", msg.report().rows_size(), " entries takes ", bytes,
      " bytes, over the server's message limit of ", max_message_bytes,
      " bytes (--max_message_bytes); ask for fewer samples"));
}

absl::StatusOr<int> ChunkSamplesFromWire(int chunk_vertices) {
  const int chunk =
      chunk_vertices == 0 ? kDefaultChunkVertices : chunk_vertices;
  if (chunk < 1 || chunk > kMaxChunkVertices) {
    return absl::InvalidArgumentError(
        absl::StrCat("chunk_vertices must be in [1, ", kMaxChunkVertices,
                     "] (0 = ", kDefaultChunkVertices, "), got ", chunk));
  }
  return chunk;
}

SdfChunker::SdfChunker(const SparseJacobian* jacobian, int dimension,
                       int64_t samples, int chunk, int64_t max_message_bytes)
    : jacobian_(jacobian),
      dimension_(dimension),
      samples_(samples),
      chunk_(chunk),
      max_message_bytes_(max_message_bytes),
      budget_(max_message_bytes / 2) {}

int64_t SdfChunker::SampleBytes(int64_t p) const {
  if (jacobian_ == nullptr) return 40;
  const auto& offsets = jacobian_->row_offsets;
  return 40 + (offsets[p + 1] - offsets[p]) * (4 + 8 * dimension_);
}

absl::Status SdfChunker::CheckRows() const {
  for (int64_t p = 0; jacobian_ != nullptr && p < samples_; ++p) {
    if (SampleBytes(p) > budget_) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "sample ", p, "'s Jacobian row takes about ", SampleBytes(p),
          " bytes, more than half the message limit of ", max_message_bytes_,
          " bytes (--max_message_bytes); use fewer rays or ask for the VJP "
          "instead"));
    }
  }
  return absl::OkStatus();
}

int64_t SdfChunker::ChunkEnd(int64_t begin) const {
  const int64_t end = std::min(samples_, begin + chunk_);
  // End the chunk early so that its values (and rows) fit in one message.
  int64_t bytes = 0;
  for (int64_t p = begin; p < end; ++p) {
    bytes += SampleBytes(p);
    if (bytes > budget_ && p > begin) return p;
  }
  return end;
}

}  // namespace meshgauge::wire

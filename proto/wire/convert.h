// The one conversion layer between the wire (meshgauge/v1/meshgauge.proto)
// and the library's types, used by the server and the C++ client alike.
// ToWire* writes a message from library values; From* reads one back and
// validates what a peer could get wrong (INVALID_ARGUMENT naming the field;
// DATA_LOSS for a malformed reply).
#pragma once

#include <grpcpp/support/status.h>

#include <cstdint>
#include <optional>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/calibration_types.h"
#include "lib/core/mesh.h"
#include "lib/core/penalty.h"
#include "lib/core/sdf_types.h"
#include "lib/core/thin_regions.h"
#include "meshgauge/v1/meshgauge.pb.h"
#include "proto/wire/types.h"

namespace meshgauge::wire {

// Parameters. Threads (ComputeControl) are the server's business and are
// not sent.
v1::SdfParameters ToWire(const SdfParams& p);
// Zero fields select the defaults; rays are limited to max_rays.
// Errors: INVALID_ARGUMENT naming the field.
absl::StatusOr<SdfParams> FromWire(const v1::SdfParameters& p, int max_rays);
void ToWire(const PenaltyParams& p, v1::ComputePenaltyRequest* out);
void ToWire(const PenaltyParams& p, v1::PenaltyParameters* out);
absl::StatusOr<PenaltyParams> PenaltyFromWire(
    const v1::ComputePenaltyRequest& r);
absl::StatusOr<PenaltyParams> PenaltyFromWire(const v1::PenaltyParameters& r);
// nullopt without with_thin_regions. Errors: INVALID_ARGUMENT naming the
// field (min_region_area < 0, max_thin_regions outside 0..100000).
absl::StatusOr<std::optional<ThinRequest>> ThinFromWire(
    const v1::ComputePenaltyRequest& r);
void ToWire(const CalibrationParams& p, v1::CalibrateRequest* out);
// `sdf` is the request's parameters already read with FromWire.
CalibrationParams CalibrationFromWire(const v1::CalibrateRequest& r,
                                      const SdfParams& sdf);

// A request's sample range. Errors: INVALID_ARGUMENT naming the range
// unless 0 <= begin < end (the mesh's count is checked by the call).
absl::StatusOr<SampleRange> FromWire(const v1::SampleRange& r);
void ToWire(const SampleRange& r, v1::SampleRange* out);

// Enums.
v1::VertexStatus ToWire(VertexStatus s);
absl::StatusOr<VertexStatus> FromWire(v1::VertexStatus s);
v1::ConeDirection ToWire(ConeDirection d);
absl::StatusOr<ConeDirection> FromWire(v1::ConeDirection d);

// Values.
void ToWire(const MissingValues& m, v1::MissingValues* out);
MissingValues FromWire(const v1::MissingValues& m);
void ToWire(const SessionInfo& s, v1::SessionInfo* out);
SessionInfo FromWire(const v1::SessionInfo& s);
void ToWire(const CalibrationReport& r, v1::CalibrateResponse* out);
// The largest `max_regions` regions (face_region is not sent).
void ToWire(const ThinSurface& t, int max_regions, v1::ThinSurface* out);
// t_min is the request's. Errors: DATA_LOSS for a point without 3 values.
absl::StatusOr<ThinSurface> FromWire(const v1::ThinSurface& t, double t_min);
CalibrationReport FromWire(const v1::CalibrateResponse& r);

// `dimension` doubles per vertex.
void AppendFlattened(absl::Span<const Vec3> v, int dimension,
                     google::protobuf::RepeatedField<double>* out);
// Each face's vertex count to `sizes`, its vertices to `indices`.
void AppendFaces(absl::Span<const Face> faces,
                 google::protobuf::RepeatedField<int32_t>* sizes,
                 google::protobuf::RepeatedField<int32_t>* indices);
// Errors: INVALID_ARGUMENT when the count is not a multiple of dimension or
// a value is not finite.
absl::StatusOr<std::vector<Vec3>> ToPoints(
    const google::protobuf::RepeatedField<double>& flat, int dimension,
    const char* field);

// The ComputeSdf stream. The server writes chunks of [begin, end) of a
// result (with the Jacobian's rows when `jacobian` is given), then the
// summary; the client appends them in order to an SdfReply.
// With a range pass, [begin, end) index its result and the chunk names the
// samples range.begin + begin .. range.begin + end.
void ToWireChunk(const SdfResult& r, const SparseJacobian* jacobian,
                 int dimension, int64_t begin, int64_t end, v1::SdfChunk* out);
// `facts` and `integral` are the call's; the rest comes from the result.
void ToWireSummary(const SdfResult& r, double integral, const CallFacts& facts,
                   v1::SdfSummary* out);
// Errors: DATA_LOSS when the chunk does not continue the reply or its
// arrays disagree. `first_sample`: the range's first sample (0 for a whole
// pass), the sample of the reply's first entry.
absl::Status AppendChunk(const v1::SdfChunk& c, SdfReply* reply,
                         int64_t first_sample = 0);
// Completes the reply with the summary; `params` are the ones sent.
// Errors: DATA_LOSS when the summary's counts are not the vertices the
// chunks carried, the opposite points are not the ones asked for, or the
// summary's range is not params.range (a server older than ranges).
absl::Status FinishReply(const v1::SdfSummary& s, const SdfParams& params,
                         SdfReply* reply);

// The mesh and its generation as GetMesh returns them.
void ToWire(const Mesh& mesh, int64_t generation, v1::GetMeshResponse* out);

grpc::Status ToGrpc(const absl::Status& s);
absl::Status FromGrpc(const grpc::Status& s);

}  // namespace meshgauge::wire

// Conversions between the wire types and the library's.
#pragma once

#include <grpcpp/support/status.h>

#include "absl/status/statusor.h"
#include "lib/core/penalty.h"
#include "lib/core/sdf_types.h"
#include "meshgauge/v1/meshgauge.pb.h"
#include "server/session.h"

namespace meshgauge::server {

// Wire parameters to SdfParams (zero fields select defaults), validated,
// with rays limited to max_rays. Errors: INVALID_ARGUMENT naming the field.
absl::StatusOr<SdfParams> ToSdfParams(const v1::SdfParameters& p, int max_rays,
                                      int threads);

absl::StatusOr<PenaltyParams> ToPenaltyParams(
    const v1::ComputePenaltyRequest& r);

v1::VertexStatus ToProto(VertexStatus s);
void ToProto(const MissingValues& m, v1::MissingValues* out);
void ToProto(const SessionSnapshot& s, double now, v1::SessionInfo* out);

// Flattens per-vertex 3-vectors into `dimension` doubles per vertex.
void AppendFlattened(const std::vector<Vec3>& v, int dimension,
                     google::protobuf::RepeatedField<double>* out);

// Reads `dimension` doubles per vertex. Errors: INVALID_ARGUMENT when the
// count is not a multiple of dimension or a value is not finite.
absl::StatusOr<std::vector<Vec3>> ToPoints(
    const google::protobuf::RepeatedField<double>& flat, int dimension,
    const char* field);

grpc::Status ToGrpc(const absl::Status& s);

}  // namespace meshgauge::server

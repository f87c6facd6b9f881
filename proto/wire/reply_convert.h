// The unary replies both sides use (GetServerInfo, UpdatePositions,
// ComputeVjp, ComputePenalty) and the health response, part of the conversion
// layer of convert.h.
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "meshgauge/v1/meshgauge.pb.h"
#include "proto/wire/types.h"

namespace meshgauge::wire {

void ToWire(const ServerInfo& r, v1::GetServerInfoResponse* out);
ServerInfo FromWire(const v1::GetServerInfoResponse& r);

void ToWire(const UpdateResult& r, v1::UpdatePositionsResponse* out);
UpdateResult FromWire(const v1::UpdatePositionsResponse& r);

// `dimension` (2 or 3) values per vertex of the gradient are sent.
void ToWire(const VjpReply& r, int dimension, v1::ComputeVjpResponse* out);
// Errors: DATA_LOSS (a dimension other than 2 or 3, a gradient that is not
// whole vectors).
absl::StatusOr<VjpReply> FromWire(const v1::ComputeVjpResponse& r);

// The penalty's fields (its gradient when `with_gradient`); the thin
// surface is the server's to add.
void ToWire(const PenaltyReply& r, int dimension, bool with_gradient,
            v1::ComputePenaltyResponse* out);
// Errors: as for the VJP's gradient (read when `with_gradient`).
absl::StatusOr<PenaltyReply> FromWire(const v1::ComputePenaltyResponse& r,
                                      bool with_gradient);

// grpc.health.v1.HealthCheckResponse as bytes (the clients carry no health
// stubs): true for SERVING, false for NOT_SERVING. Errors: DATA_LOSS for
// anything else.
absl::StatusOr<bool> ServingFromHealthBytes(const std::string& bytes);

}  // namespace meshgauge::wire

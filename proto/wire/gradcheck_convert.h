// The wire form of the finite-difference check (GradCheck RPC): its options
// and its report, part of the conversion layer of convert.h.
#pragma once

#include <cstdint>

#include "absl/status/statusor.h"
#include "lib/core/gradcheck_types.h"
#include "meshgauge/v1/meshgauge.pb.h"

namespace meshgauge::wire {

// The most vertices one GradCheck call samples or lists.
inline constexpr int kMaxGradCheckVertices = 1000;

// The options' fields of the request (session, parameters and generation
// are the caller's).
void ToWire(const GradCheckOptions& o, v1::GradCheckRequest* out);
// Errors: INVALID_ARGUMENT naming the field (samples outside 0..1000, more
// than 1000 vertices, the penalty's). The ranges of the step, tolerance and
// clean fraction are RunGradCheck's to check.
absl::StatusOr<GradCheckOptions> GradCheckFromWire(
    const v1::GradCheckRequest& r);

void ToWire(const GradCheckReport& r, int64_t generation,
            v1::GradCheckReport* out);
// Errors: DATA_LOSS for a coordinate outside 0..2 or a verdict that its
// counts contradict.
absl::StatusOr<GradCheckReport> FromWire(const v1::GradCheckReport& r);

}  // namespace meshgauge::wire

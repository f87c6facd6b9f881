// The fan-out of one call over sample ranges (docs/server.md, Fan-out):
// how a client splits the samples, runs the range calls at once and merges
// their replies into the whole call's, bit for bit.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"
#include "proto/wire/types.h"

namespace meshgauge::client {

// `k` contiguous ranges of nearly equal size covering [0, samples) (fewer
// when there are fewer samples than k; none for no sample).
std::vector<SampleRange> SplitSamples(int64_t samples, int k);

// Runs call(i) for i in [0, n) on n threads at once and returns the first
// error in index order.
absl::Status RunConcurrently(int n, const std::function<absl::Status(int)>& call);

// The whole ComputeSdf reply from its ranges' (any order, covering the
// samples of `mesh` once): per-sample arrays and Jacobian rows in sample
// order, normalized values, missing counts and the integral computed from
// the merged values as the server computes them, rays and frame fallbacks
// summed. Errors: ABORTED when the ranges are of different generations (the
// session moved during the call), DATA_LOSS when they do not tile the
// samples.
absl::StatusOr<wire::SdfReply> MergeSdfReplies(const Mesh& mesh,
                                               std::vector<wire::SdfReply> parts);

// The whole ComputeVjp reply from its ranges' exact partial sums (any
// order): summed exactly and rounded once. Errors: ABORTED as above,
// DATA_LOSS for a part without sums of `vertices` vertices.
absl::StatusOr<wire::VjpReply> MergeVjpReplies(
    int64_t vertices, const std::vector<wire::VjpReply>& parts);

// The whole ComputePenalty reply from its ranges' (in range order, the
// first beginning at sample 0): the value, missing counts and sdf_min of
// the first (every range computes them from the same values), frame
// fallbacks summed, and with `with_gradient` PenaltyGradient of the ranges'
// exact VJP sums added and the first range's measure part. Errors: ABORTED
// as above, DATA_LOSS for a part without its sums.
absl::StatusOr<wire::PenaltyReply> MergePenaltyReplies(
    std::vector<wire::PenaltyReply> parts, bool with_gradient);

}  // namespace meshgauge::client

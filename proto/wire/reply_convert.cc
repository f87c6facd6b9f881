#include "proto/wire/reply_convert.h"

#include "absl/strings/str_cat.h"
#include "lib/core/sensitivity.h"
#include "proto/wire/convert.h"

namespace meshgauge::wire {
namespace {

// Per-vertex vectors of a reply's gradient.
absl::StatusOr<std::vector<Vec3>> Gradient(
    const google::protobuf::RepeatedField<double>& flat, int dimension) {
  if (dimension != 2 && dimension != 3) {
    return absl::DataLossError(
        absl::StrCat("reply gradient dimension ", dimension));
  }
  auto points = ToPoints(flat, dimension, "gradient");
  if (!points.ok()) return absl::DataLossError(points.status().message());
  return points;
}

// A range's exact partial sums (x, y, z per vertex; `dimension` of them
// sent): after each sum's rounding (sent as the gradient), the count of its
// further terms and the terms. Nothing for no sums (a whole call).
void AppendTails(const ExactSums& sums, int dimension,
                 google::protobuf::RepeatedField<int32_t>* counts,
                 google::protobuf::RepeatedField<double>* tails) {
  for (int64_t j = 0; 3 * j < sums.size(); ++j) {
    for (int c = 0; c < dimension; ++c) {
      const std::vector<double> terms = sums.Terms(3 * j + c);
      const int tail = terms.empty() ? 0 : static_cast<int>(terms.size()) - 1;
      counts->Add(tail);
      for (int t = 1; t <= tail; ++t) tails->Add(terms[t]);
    }
  }
}

// The exact sums of a reply's rounded values and tails (AppendTails); no
// sums without tail counts. DATA_LOSS when the counts do not match.
absl::StatusOr<ExactSums> SumsFromWire(
    const google::protobuf::RepeatedField<double>& rounded, int dimension,
    const google::protobuf::RepeatedField<int32_t>& counts,
    const google::protobuf::RepeatedField<double>& tails) {
  if (counts.empty()) return ExactSums();
  if (counts.size() != rounded.size() || dimension <= 0) {
    return absl::DataLossError(absl::StrCat("the reply has ", counts.size(),
                                            " tail counts for ", rounded.size(),
                                            " gradient values"));
  }
  ExactSums sums(3 * (rounded.size() / dimension));
  int tail = 0;
  for (int i = 0; i < rounded.size(); ++i) {
    const int64_t sum = 3 * (i / dimension) + i % dimension;
    sums.Add(sum, rounded[i]);
    if (counts[i] < 0 || counts[i] > tails.size() - tail) {
      return absl::DataLossError("the reply's tails do not match its counts");
    }
    for (const int end = tail + counts[i]; tail < end; ++tail) {
      sums.Add(sum, tails[tail]);
    }
  }
  if (tail != tails.size()) {
    return absl::DataLossError("the reply's tails do not match its counts");
  }
  return sums;
}

}  // namespace

void ToWire(const ServerInfo& r, v1::GetServerInfoResponse* out) {
  out->set_version(r.version);
  out->set_api(r.api);
  out->set_max_rays(r.max_rays);
  out->set_max_vertices(r.max_vertices);
  out->set_max_faces(r.max_faces);
  out->set_max_message_bytes(r.max_message_bytes);
  out->set_max_upload_message_bytes(r.max_upload_message_bytes);
  out->set_max_upload_file_bytes(r.max_upload_file_bytes);
  out->set_max_sessions(r.max_sessions);
  out->set_memory_budget_bytes(r.memory_budget_bytes);
}

ServerInfo FromWire(const v1::GetServerInfoResponse& r) {
  return {.version = r.version(),
          .api = r.api(),
          .max_rays = r.max_rays(),
          .max_vertices = r.max_vertices(),
          .max_faces = r.max_faces(),
          .max_message_bytes = r.max_message_bytes(),
          .max_upload_message_bytes = r.max_upload_message_bytes(),
          .max_upload_file_bytes = r.max_upload_file_bytes(),
          .max_sessions = r.max_sessions(),
          .memory_budget_bytes = r.memory_budget_bytes()};
}

void ToWire(const UpdateResult& r, v1::UpdatePositionsResponse* out) {
  out->set_generation(r.generation);
  out->set_refit(r.refit);
  out->set_bvh_seconds(r.bvh_seconds);
}

UpdateResult FromWire(const v1::UpdatePositionsResponse& r) {
  return {r.generation(), r.refit(), r.bvh_seconds()};
}

void ToWire(const VjpReply& r, int dimension, v1::ComputeVjpResponse* out) {
  out->set_generation(r.facts.generation);
  out->set_dimension(dimension);
  AppendFlattened(r.gradient, dimension, out->mutable_gradient());
  AppendTails(r.sums, dimension, out->mutable_tail_counts(),
              out->mutable_tails());
  out->set_reused_hits(r.facts.reused_hits);
  out->set_seconds(r.facts.seconds);
}

absl::StatusOr<VjpReply> FromWire(const v1::ComputeVjpResponse& r) {
  auto gradient = Gradient(r.gradient(), r.dimension());
  if (!gradient.ok()) return gradient.status();
  auto sums = SumsFromWire(r.gradient(), r.dimension(), r.tail_counts(),
                           r.tails());
  if (!sums.ok()) return sums.status();
  return VjpReply{std::move(*gradient),
                  {r.generation(), r.reused_hits(), r.seconds()},
                  std::move(*sums)};
}

void ToWire(const PenaltyReply& r, int dimension, bool with_gradient,
            v1::ComputePenaltyResponse* out) {
  out->set_generation(r.facts.generation);
  out->set_value(r.penalty.value);
  out->set_skipped_faces(r.penalty.missing.faces);
  ToWire(r.penalty.missing, out->mutable_missing());
  out->set_world_frame_vertices(r.world_frame_vertices);
  out->set_dimension(dimension);
  if (with_gradient && r.penalty.vjp_sums.size() > 0) {  // a range's part
    AppendFlattened(RoundVectors(r.penalty.vjp_sums), dimension,
                    out->mutable_gradient());
    AppendTails(r.penalty.vjp_sums, dimension, out->mutable_tail_counts(),
                out->mutable_tails());
    AppendFlattened(r.penalty.measure_gradient, dimension,
                    out->mutable_measure_gradient());
  } else if (with_gradient) {
    AppendFlattened(r.penalty.gradient, dimension, out->mutable_gradient());
  }
  out->set_sdf_min(r.sdf_min);
  out->set_reused_hits(r.facts.reused_hits);
  out->set_seconds(r.facts.seconds);
}

absl::StatusOr<PenaltyReply> FromWire(const v1::ComputePenaltyResponse& r,
                                      bool with_gradient) {
  PenaltyReply out;
  out.penalty.value = r.value();
  out.penalty.missing = FromWire(r.missing());
  if (with_gradient && r.tail_counts_size() > 0) {  // a range's part
    auto sums = SumsFromWire(r.gradient(), r.dimension(), r.tail_counts(),
                             r.tails());
    if (!sums.ok()) return sums.status();
    out.penalty.vjp_sums = std::move(*sums);
    if (r.measure_gradient_size() > 0) {
      auto measure = Gradient(r.measure_gradient(), r.dimension());
      if (!measure.ok()) return measure.status();
      out.penalty.measure_gradient = std::move(*measure);
    }
  } else if (with_gradient) {
    auto gradient = Gradient(r.gradient(), r.dimension());
    if (!gradient.ok()) return gradient.status();
    out.penalty.gradient = std::move(*gradient);
  }
  out.sdf_min = r.sdf_min();
  out.world_frame_vertices = r.world_frame_vertices();
  out.facts = {r.generation(), r.reused_hits(), r.seconds()};
  return out;
}

absl::StatusOr<bool> ServingFromHealthBytes(const std::string& bytes) {
  // Field 1 (status) as a varint: 1 = SERVING, 2 = NOT_SERVING.
  if (bytes.size() != 2 || bytes[0] != 0x08 ||
      (bytes[1] != 1 && bytes[1] != 2)) {
    return absl::DataLossError("unexpected health response");
  }
  return bytes[1] == 1;
}

}  // namespace meshgauge::wire

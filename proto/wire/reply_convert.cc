#include "proto/wire/reply_convert.h"

#include "absl/strings/str_cat.h"
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
  // A range's sums: each the rounded value sent above, then its tail.
  for (int64_t j = 0; 3 * j < r.sums.size(); ++j) {
    for (int c = 0; c < dimension; ++c) {
      const std::vector<double> terms = r.sums.Terms(3 * j + c);
      const int tail = terms.empty() ? 0 : static_cast<int>(terms.size()) - 1;
      out->add_tail_counts(tail);
      for (int t = 1; t <= tail; ++t) out->add_tails(terms[t]);
    }
  }
  out->set_reused_hits(r.facts.reused_hits);
  out->set_seconds(r.facts.seconds);
}

absl::StatusOr<VjpReply> FromWire(const v1::ComputeVjpResponse& r) {
  auto gradient = Gradient(r.gradient(), r.dimension());
  if (!gradient.ok()) return gradient.status();
  VjpReply out{std::move(*gradient),
               {r.generation(), r.reused_hits(), r.seconds()},
               {}};
  if (r.tail_counts_size() == 0) return out;
  if (r.tail_counts_size() != r.gradient_size()) {
    return absl::DataLossError(absl::StrCat(
        "the reply has ", r.tail_counts_size(), " tail counts for ",
        r.gradient_size(), " gradient values"));
  }
  out.sums = ExactSums(3 * std::ssize(out.gradient));
  int tail = 0;
  for (int i = 0; i < r.gradient_size(); ++i) {
    const int64_t sum = 3 * (i / r.dimension()) + i % r.dimension();
    out.sums.Add(sum, r.gradient(i));
    if (r.tail_counts(i) < 0 || r.tail_counts(i) > r.tails_size() - tail) {
      return absl::DataLossError("the reply's tails do not match its counts");
    }
    for (const int end = tail + r.tail_counts(i); tail < end; ++tail) {
      out.sums.Add(sum, r.tails(tail));
    }
  }
  if (tail != r.tails_size()) {
    return absl::DataLossError("the reply's tails do not match its counts");
  }
  return out;
}

void ToWire(const PenaltyReply& r, int dimension, bool with_gradient,
            v1::ComputePenaltyResponse* out) {
  out->set_generation(r.facts.generation);
  out->set_value(r.penalty.value);
  out->set_skipped_faces(r.penalty.missing.faces);
  ToWire(r.penalty.missing, out->mutable_missing());
  out->set_world_frame_vertices(r.world_frame_vertices);
  out->set_dimension(dimension);
  if (with_gradient) {
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
  if (with_gradient) {
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

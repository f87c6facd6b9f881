#include "client/remote/fan_out.h"

#include <algorithm>
#include <thread>

#include "absl/strings/str_cat.h"
#include "lib/core/exact_sum.h"
#include "lib/core/face_sample.h"
#include "lib/core/integrals.h"
#include "lib/core/missing_values.h"
#include "lib/core/normalized_sdf.h"
#include "lib/core/penalty.h"
#include "lib/core/sensitivity.h"

namespace meshgauge::client {
namespace {

// The facts of a fanned-out call: its parts' generation (all equal, else
// ABORTED), reused when every part was, the slowest part's time.
absl::StatusOr<wire::CallFacts> MergeFacts(
    const std::vector<wire::CallFacts>& facts) {
  wire::CallFacts out = facts.front();
  for (const wire::CallFacts& f : facts) {
    if (f.generation != out.generation) {
      return absl::AbortedError(absl::StrCat(
          "the session moved during a fanned-out call: ranges computed at "
          "generations ",
          out.generation, " and ", f.generation, "; call again"));
    }
    out.reused_hits = out.reused_hits && f.reused_hits;
    out.seconds = std::max(out.seconds, f.seconds);
  }
  return out;
}

// Adds a range's exact partial sums to the merged ones, exactly.
void AddSums(const ExactSums& part, ExactSums* total) {
  for (int64_t i = 0; i < total->size(); ++i) {
    for (double t : part.Terms(i)) total->Add(i, t);
  }
}

template <typename T>
void Append(std::vector<T>* to, const std::vector<T>& from) {
  to->insert(to->end(), from.begin(), from.end());
}

void AppendRows(const SparseJacobian& part, SparseJacobian* out) {
  if (out->row_offsets.empty()) out->row_offsets.push_back(0);
  const int64_t base = out->nonzeros();
  for (size_t r = 1; r < part.row_offsets.size(); ++r) {
    out->row_offsets.push_back(base + part.row_offsets[r]);
  }
  Append(&out->columns, part.columns);
  Append(&out->values, part.values);
}

}  // namespace

std::vector<SampleRange> SplitSamples(int64_t samples, int k) {
  const int64_t n = std::min<int64_t>(std::max(k, 1), samples);
  std::vector<SampleRange> ranges;
  for (int64_t i = 0; i < n; ++i) {
    ranges.push_back({samples * i / n, samples * (i + 1) / n});
  }
  return ranges;
}

absl::Status RunConcurrently(int n,
                             const std::function<absl::Status(int)>& call) {
  std::vector<absl::Status> status(n);
  std::vector<std::thread> threads;
  threads.reserve(n);
  for (int i = 0; i < n; ++i) {
    threads.emplace_back([&, i] { status[i] = call(i); });
  }
  for (std::thread& t : threads) t.join();
  for (const absl::Status& s : status) {
    if (!s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::StatusOr<wire::SdfReply> MergeSdfReplies(
    const Mesh& mesh, std::vector<wire::SdfReply> parts) {
  if (parts.empty()) return absl::DataLossError("no range replied");
  std::sort(parts.begin(), parts.end(), [](const auto& a, const auto& b) {
    return a.result.resolved.params.range.begin <
           b.result.resolved.params.range.begin;
  });
  std::vector<wire::CallFacts> facts;
  wire::SdfReply out;
  SdfResult& r = out.result;
  r.resolved = parts.front().result.resolved;
  r.resolved.params.range = {};
  if (parts.front().jacobian) out.jacobian.emplace();
  int64_t next = 0;
  for (const wire::SdfReply& part : parts) {
    const SdfResult& p = part.result;
    const SampleRange range = p.resolved.params.range;
    if (range.begin != next || std::ssize(p.values) != range.end - range.begin ||
        part.jacobian.has_value() != out.jacobian.has_value()) {
      return absl::DataLossError(absl::StrCat(
          "the ranges do not tile the samples: [", range.begin, ", ",
          range.end, ") follows sample ", next));
    }
    next = range.end;
    Append(&r.values, p.values);
    Append(&r.status, p.status);
    Append(&r.hits, p.hits);
    Append(&r.kept, p.kept);
    Append(&r.opposite, p.opposite);
    if (out.jacobian) AppendRows(*part.jacobian, &*out.jacobian);
    r.rays_traced += p.rays_traced;
    r.world_frame_vertices += p.world_frame_vertices;
    r.trace_seconds = std::max(r.trace_seconds, p.trace_seconds);
    facts.push_back(part.facts);
  }
  if (next != NumSamples(mesh, r.resolved.params.samples)) {
    return absl::DataLossError(absl::StrCat("the ranges cover ", next, " of ",
                                            NumSamples(mesh, r.resolved.params.samples),
                                            " samples"));
  }
  auto merged_facts = MergeFacts(facts);
  if (!merged_facts.ok()) return merged_facts.status();
  out.facts = *merged_facts;
  // What needs every value, computed as the server's whole pass does.
  r.normalized = NormalizedSdf(r.values);
  r.missing = r.resolved.params.samples == SampleSet::kFaces
                  ? CountMissingFaces(mesh, r.values)
                  : CountMissing(mesh, r.values);
  out.integral = IntegrateSdf(mesh, r).value;
  return out;
}

absl::StatusOr<wire::VjpReply> MergeVjpReplies(
    int64_t vertices, const std::vector<wire::VjpReply>& parts) {
  if (parts.empty()) return absl::DataLossError("no range replied");
  ExactSums sums(3 * vertices);
  std::vector<wire::CallFacts> facts;
  for (const wire::VjpReply& part : parts) {
    if (part.sums.size() != 3 * vertices) {
      return absl::DataLossError(absl::StrCat(
          "a range's reply holds ", part.sums.size() / 3, " partial sums for ",
          vertices, " vertices (is the server older than ranges?)"));
    }
    AddSums(part.sums, &sums);
    facts.push_back(part.facts);
  }
  auto merged_facts = MergeFacts(facts);
  if (!merged_facts.ok()) return merged_facts.status();
  return wire::VjpReply{RoundVectors(sums), *merged_facts, {}};
}

absl::StatusOr<wire::PenaltyReply> MergePenaltyReplies(
    std::vector<wire::PenaltyReply> parts, bool with_gradient) {
  if (parts.empty()) return absl::DataLossError("no range replied");
  std::vector<wire::CallFacts> facts;
  int64_t frames = 0;
  for (const wire::PenaltyReply& part : parts) {
    facts.push_back(part.facts);
    frames += part.world_frame_vertices;
  }
  auto merged_facts = MergeFacts(facts);
  if (!merged_facts.ok()) return merged_facts.status();
  wire::PenaltyReply out = std::move(parts.front());
  out.facts = *merged_facts;
  out.world_frame_vertices = frames;
  if (!with_gradient) return out;
  const int64_t sums = out.penalty.vjp_sums.size();
  if (sums == 0 || std::ssize(out.penalty.measure_gradient) * 3 != sums) {
    return absl::DataLossError(
        "the first range's penalty reply has no exact partial sums or no "
        "measure part (is the server older than penalty ranges?)");
  }
  ExactSums total(sums);
  AddSums(out.penalty.vjp_sums, &total);
  for (size_t i = 1; i < parts.size(); ++i) {
    if (parts[i].penalty.vjp_sums.size() != sums) {
      return absl::DataLossError(absl::StrCat(
          "range ", i, "'s penalty reply holds ",
          parts[i].penalty.vjp_sums.size() / 3, " partial sums for ",
          sums / 3, " vertices"));
    }
    AddSums(parts[i].penalty.vjp_sums, &total);
  }
  out.penalty.gradient = PenaltyGradient(total, out.penalty.measure_gradient);
  out.penalty.vjp_sums = ExactSums();
  return out;
}

}  // namespace meshgauge::client

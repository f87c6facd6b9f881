#include "server/session_calls.h"

#include <bit>
#include <utility>

#include "absl/strings/str_cat.h"
#include "lib/core/face_sample.h"
#include "lib/core/integrals.h"
#include "lib/core/missing_diagnosis.h"
#include "lib/core/stopwatch.h"
#include "lib/embree/calibration.h"
#include "lib/embree/gradcheck.h"
#include "lib/embree/ray_scene.h"
#include "proto/wire/reply_bytes.h"
#include "server/session_messages.h"

namespace meshgauge::server {
namespace {

int64_t FullPassRays(const SdfEvaluator& ev, const SdfParams& params) {
  return NumSamples(ev.mesh(), params.samples) *
         int64_t{ResolveParams(params, ev.mesh().dimension).rays};
}

// The library's control of `control` on `threads` threads (0: all cores);
// with `rays_total` (> 0) its progress too.
ComputeControl LibraryControl(const CallControl& control, int threads,
                              int64_t rays_total = 0) {
  ComputeControl c;
  c.threads = threads;
  c.cancelled = control.cancelled;
  if (control.progress && rays_total > 0) {
    c.progress = [progress = control.progress, rays_total](int64_t done,
                                                           int64_t total) {
      progress({done, total, rays_total});
    };
  }
  return c;
}

// A penalty range call's SdfResult: `values`, every sample's, checked
// against the range pass `part` (its samples' values bit for bit), with the
// part's resolved parameters over every sample. Its statuses are the
// part's: the missing-value error's likely cause names what this range saw.
absl::StatusOr<SdfResult> WithValuesOfEverySample(
    const Mesh& mesh, const SdfResult& part, absl::Span<const double> values) {
  const SampleSet set = part.resolved.params.samples;
  const int64_t n = NumSamples(mesh, set);
  if (std::ssize(values) != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("values holds ", values.size(), " values, expected one per ",
                     SampleName(set), " (", n, ")"));
  }
  const SampleRange range = part.resolved.params.range;
  for (int64_t i = range.begin; i < range.end; ++i) {
    const double mine = part.values[i - range.begin];
    if (std::bit_cast<uint64_t>(values[i]) != std::bit_cast<uint64_t>(mine)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "values[", i, "] is ", values[i], ", this session's pass has ", mine,
          ": values must be the fanned-out ComputeSdf's of the same "
          "parameters and generation"));
    }
  }
  SdfResult whole;
  whole.resolved = part.resolved;
  whole.resolved.params.range = {};
  whole.values.assign(values.begin(), values.end());
  whole.status = part.status;
  return whole;
}

}  // namespace

absl::Status CallControl::Interrupted(absl::Status s) const {
  if (s.code() != absl::StatusCode::kCancelled) return s;
  if (deadline <= std::chrono::system_clock::now()) {
    return absl::DeadlineExceededError("deadline exceeded during computation");
  }
  return absl::CancelledError("call cancelled by the client");
}

SessionCalls::SessionCalls(const ServerOptions& options, SessionStore* store,
                           Metrics* metrics)
    : options_(options),
      store_(store),
      metrics_(metrics),
      slots_(options.ComputationsPerTenant(),
             options.ConcurrentComputations()) {}

absl::StatusOr<SessionCalls::Prepared> SessionCalls::Prepare(
    const std::string& tenant, const SessionTarget& target,
    const CallControl& control) {
  // The slot first: a queued call holds no session lock.
  auto slot = slots_.Take(tenant, [&control] {
    return control.cancelled() ||
           std::chrono::system_clock::now() >= control.deadline;
  });
  if (!slot.ok()) return control.Interrupted(slot.status());
  auto session = store_->Get(tenant, target.session_id);
  if (!session.ok()) return session.status();
  auto reader = (*session)->Read();
  if (!reader.ok()) return reader.status();
  const int64_t generation = reader->generation();
  if (target.expected_generation && *target.expected_generation != generation) {
    return GenerationMismatch(target.session_id, generation,
                              *target.expected_generation, "request");
  }
  if (auto range = ResolveRange(reader->evaluator->mesh(), target.params);
      !range.ok()) {
    return range.status();
  }
  return Prepared{std::move(*slot), std::move(*session), std::move(*reader),
                  target.params};
}

absl::StatusOr<SessionCalls::Pass> SessionCalls::EnsurePass(
    const std::string& tenant, const Prepared& prep, const CallControl& control,
    bool with_progress) {
  const SdfEvaluator& ev = prep.evaluator();
  const SdfParams& params = prep.params;
  Session& session = *prep.session;
  if (auto cached = session.FindPass(params, ev.generation())) {
    return Pass{std::move(cached), true};
  }
  // Counted in the session's memory once stored; until then a claim.
  auto claim = store_->ClaimScratch(tenant, prep.session,
                                    EstimatePassBytes(ev.mesh(), params),
                                    "this ray pass's hit table and values");
  if (!claim.ok()) return claim.status();
  // The rays of the session's last pass with these parameters (an earlier
  // generation's) are reused where they cannot have changed.
  const std::shared_ptr<const CachedPass> last = session.LatestPass(params);
  const PreviousPass previous{last ? &last->result : nullptr,
                              last ? &last->hits : nullptr};
  auto pass = std::make_shared<CachedPass>();
  auto result =
      ev.Compute(params,
                 LibraryControl(control, options_.compute_threads,
                                with_progress ? FullPassRays(ev, params) : 0),
                 &pass->hits, &previous);
  if (!result.ok()) return control.Interrupted(result.status());
  metrics_->AddRays(static_cast<double>(result->rays_traced));
  pass->params = params;
  pass->generation = ev.generation();
  pass->result = std::move(*result);
  pass->bytes = PassBytes(pass->result, pass->hits);
  session.StorePass(pass);
  claim->reset();  // the session's memory now counts the pass.
  store_->EnforceBudget(&session);
  return Pass{std::move(pass), false};
}

absl::StatusOr<SdfOutcome> SessionCalls::Sdf(const std::string& tenant,
                                             const SessionTarget& target,
                                             bool with_jacobian,
                                             const CallControl& control) {
  const Stopwatch start;
  auto prep = Prepare(tenant, target, control);
  if (!prep.ok()) return prep.status();
  auto pass = EnsurePass(tenant, *prep, control, /*with_progress=*/true);
  if (!pass.ok()) return pass.status();
  const SdfEvaluator& ev = prep->evaluator();
  const SdfResult& r = pass->pass->result;
  SdfOutcome out;
  if (with_jacobian) {
    auto bytes = JacobianBytesBound(ev, pass->pass->hits);
    if (!bytes.ok()) return bytes.status();
    auto claim =
        store_->ClaimScratch(tenant, prep->session, *bytes, "this Jacobian");
    if (!claim.ok()) return claim.status();
    out.jacobian_claim = std::move(*claim);
    auto j = ComputeJacobian(ev, pass->pass->hits,
                             LibraryControl(control, options_.compute_threads));
    if (!j.ok()) return control.Interrupted(j.status());
    out.jacobian = std::move(*j);
  }
  out.dimension = ev.mesh().dimension;
  // The integral and the warnings need every value: a range's reply leaves
  // them to the client that merges the ranges.
  if (prep->params.range.all()) {
    out.integral = IntegrateSdf(ev.mesh(), r).value;
    // Without a topology pass unless the missing share of the surface is
    // over the warning's.
    out.warnings = MissingValueWarnings(ev.mesh(), r);
  }
  out.facts = {ev.generation(), pass->reused, start.Seconds()};
  out.pass = std::move(pass->pass);
  return out;
}

absl::StatusOr<VjpOutcome> SessionCalls::Vjp(const std::string& tenant,
                                             const SessionTarget& target,
                                             absl::Span<const double> weights,
                                             const CallControl& control) {
  const Stopwatch start;
  auto prep = Prepare(tenant, target, control);
  if (!prep.ok()) return prep.status();
  const SdfEvaluator& ev = prep->evaluator();
  const bool range = !prep->params.range.all();
  if (absl::Status s = wire::CheckReplyBytes(
          wire::VjpReplyBytes(ev.mesh(), /*with_tails=*/range),
          options_.max_message_bytes);
      !s.ok()) {
    return s;
  }
  const SampleRange samples = *ResolveRange(ev.mesh(), prep->params);
  if (std::ssize(weights) != samples.end - samples.begin) {
    return absl::InvalidArgumentError(absl::StrCat(
        "weights holds ", weights.size(), " values, expected one per ",
        SampleName(prep->params.samples), range ? " of the range [" : " (",
        range ? absl::StrCat(samples.begin, ", ", samples.end, ")") : "",
        range ? " (" : "", samples.end - samples.begin, ")"));
  }
  auto pass = EnsurePass(tenant, *prep, control, /*with_progress=*/false);
  if (!pass.ok()) return pass.status();
  metrics_->RecordHitCache(pass->reused);
  auto sums = ComputeVjpSums(ev, pass->pass->hits, weights,
                             LibraryControl(control, options_.compute_threads));
  if (!sums.ok()) return control.Interrupted(sums.status());
  VjpOutcome out{{RoundVectors(*sums),
                  {ev.generation(), pass->reused, start.Seconds()},
                  {}},
                 ev.mesh().dimension};
  // A range's partial sums travel exactly (rounded value and tail).
  if (range) out.reply.sums = std::move(*sums);
  return out;
}

absl::StatusOr<PenaltyOutcome> SessionCalls::Penalty(
    const std::string& tenant, const SessionTarget& target,
    const PenaltyParams& penalty, const std::optional<wire::ThinRequest>& thin,
    bool with_gradient, const CallControl& control,
    absl::Span<const double> values) {
  const Stopwatch start;
  auto prep = Prepare(tenant, target, control);
  if (!prep.ok()) return prep.status();
  const SdfEvaluator& ev = prep->evaluator();
  const bool range = !prep->params.range.all();
  if (range != !values.empty()) {
    return absl::InvalidArgumentError(
        range ? "a penalty range call needs `values`, every sample's value "
                "from the fanned-out ComputeSdf"
              : "`values` are for a penalty range call only (no range set)");
  }
  const bool first_part = prep->params.range.begin == 0;
  if (absl::Status s = wire::CheckReplyBytes(
          wire::PenaltyReplyBytes(ev.mesh(), with_gradient,
                                  thin && first_part ? thin->max_regions : 0,
                                  range),
          options_.max_message_bytes);
      !s.ok()) {
    return s;
  }
  auto pass = EnsurePass(tenant, *prep, control, /*with_progress=*/false);
  if (!pass.ok()) return pass.status();
  metrics_->RecordHitCache(pass->reused);
  SdfResult supplied;
  if (range) {
    auto whole = WithValuesOfEverySample(ev.mesh(), pass->pass->result, values);
    if (!whole.ok()) return whole.status();
    supplied = std::move(*whole);
  }
  const SdfResult& sdf = range ? supplied : pass->pass->result;
  auto pen = ComputePenalty(ev, sdf, penalty,
                            with_gradient ? &pass->pass->hits : nullptr,
                            LibraryControl(control, options_.compute_threads));
  if (!pen.ok()) return control.Interrupted(pen.status());
  if (!first_part) pen->measure_gradient.clear();
  PenaltyOutcome out;
  out.dimension = ev.mesh().dimension;
  if (thin && first_part) {
    ThinRegionParams thin_params = thin->params;
    thin_params.samples = prep->params.samples;
    auto regions = FindThinRegions(ev.mesh(), sdf.values, thin_params);
    if (!regions.ok()) return regions.status();
    out.thin = std::move(*regions);
  }
  out.reply = {std::move(*pen),
               SummarizeValues(sdf.values).min,
               pass->pass->result.world_frame_vertices,
               {ev.generation(), pass->reused, start.Seconds()}};
  return out;
}

absl::StatusOr<CalibrationReport> SessionCalls::Calibrate(
    const std::string& tenant, const std::string& session_id,
    const CalibrationParams& params, const CallControl& control) {
  auto prep = Prepare(tenant, {session_id, params.sdf, std::nullopt}, control);
  if (!prep.ok()) return prep.status();
  auto report =
      meshgauge::Calibrate(prep->evaluator(), params,
                           LibraryControl(control, options_.compute_threads));
  if (!report.ok()) return control.Interrupted(report.status());
  return report;
}

absl::StatusOr<GradCheckOutcome> SessionCalls::GradCheck(
    const std::string& tenant, const SessionTarget& target,
    const GradCheckOptions& options, const CallControl& control) {
  const Stopwatch start;
  auto prep = Prepare(tenant, target, control);
  if (!prep.ok()) return prep.status();
  const int64_t generation = prep->reader.generation();
  const Mesh& mesh = prep->evaluator().mesh();
  if (absl::Status s = ValidateGradCheck(mesh, prep->params, options);
      !s.ok()) {
    return s;
  }
  const int64_t rays_total = GradCheckPasses(mesh, options) *
                             FullPassRays(prep->evaluator(), prep->params);
  // The probes move the vertices of a private evaluator: its memory is
  // claimed before it is made, and the session's lock is released once the
  // mesh is copied (before the copy's BVH is built).
  auto claim = store_->ClaimScratch(
      tenant, prep->session,
      Session::EstimateBaseBytes(mesh) + GradCheckWorkBytes(mesh, prep->params),
      "this check's private copy of the mesh and its passes");
  if (!claim.ok()) return claim.status();
  Mesh copy = mesh;
  prep->reader.lock.unlock();  // updates of the session go on.
  auto ev = SdfEvaluator::Create(std::move(copy));
  if (!ev.ok()) return ev.status();
  auto report = RunGradCheck(
      **ev, prep->params, options,
      LibraryControl(control, options_.compute_threads, rays_total));
  if (!report.ok()) return control.Interrupted(report.status());
  metrics_->AddRays(static_cast<double>(report->rays_traced));
  return GradCheckOutcome{std::move(*report),
                          {generation, false, start.Seconds()}};
}

absl::StatusOr<MeshView> SessionCalls::GetMesh(const std::string& tenant,
                                               const std::string& session_id) {
  auto session = store_->Get(tenant, session_id);
  if (!session.ok()) return session.status();
  auto reader = (*session)->Read();
  if (!reader.ok()) return reader.status();
  MeshView view{std::move(*session), std::move(*reader)};
  if (absl::Status s = wire::CheckReplyBytes(wire::MeshReplyBytes(view.mesh()),
                                             options_.max_message_bytes);
      !s.ok()) {
    return s;
  }
  return view;
}

}  // namespace meshgauge::server

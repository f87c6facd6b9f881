// meshgauge gradcheck: the SPEC §6 finite-difference verification of a
// user's mesh before an optimisation trusts its derivatives.
#include <iostream>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"
#include "client/cli/progress_bar.h"
#include "lib/core/face_sample.h"
#include "lib/embree/gradcheck.h"

namespace meshgauge::cli {
namespace {

const char* Axis(int c) { return c == 0 ? "x" : (c == 1 ? "y" : "z"); }

nlohmann::json RowJson(const GradCheckRow& r) {
  return {{"row", r.row},
          {"vertex", r.vertex},
          {"coordinate", Axis(r.coordinate)},
          {"analytic", r.analytic},
          {"fd", r.fd},
          {"relative_error", r.relative_error},
          {"clean", r.clean},
          {"step", r.step}};
}

void PrintTable(const GradCheckReport& rep, double tolerance) {
  std::cout << absl::StrFormat("%8s %8s %5s %16s %16s %10s  %s\n", "row",
                               "vertex", "coord", "analytic", "fd", "rel err",
                               "sample");
  auto line = [&](const GradCheckRow& r, const std::string& row) {
    const char* kind = !r.clean                        ? "event"
                       : r.relative_error <= tolerance ? "clean"
                                                       : "clean, FAILS";
    std::cout << absl::StrFormat("%8s %8d %5s %16.9g %16.9g %10.2e  %s\n", row,
                                 r.vertex, Axis(r.coordinate), r.analytic, r.fd,
                                 r.relative_error, kind);
  };
  for (const GradCheckRow& r : rep.rows) line(r, absl::StrCat(r.row));
  for (const GradCheckRow& r : rep.penalty_rows) line(r, "penalty");
  // analytic g^T J against sum_p g_p fd_p.
  for (const GradCheckRow& r : rep.vjp_rows) line(r, "g^T J");
}

}  // namespace

absl::Status RunGradcheck(const MeshInput& in, const GradcheckFlags& check,
                          const PenaltyFlags& penalty_flags,
                          const BackendFactory& make) {
  auto probes = check.Probes();
  if (!probes.ok()) return probes.status();
  GradCheckOptions options;
  options.samples = *probes;
  options.seed = check.seed;
  options.tolerance = check.fd_tolerance;
  if (penalty_flags.t_min != 0) {
    auto penalty = ToPenaltyParams(penalty_flags);
    if (!penalty.ok()) return penalty.status();
    options.penalty = *penalty;
  }
  auto opened = Open(in, make, /*print_warnings=*/true);
  if (!opened.ok()) return opened.status();
  const Mesh& mesh = opened->mesh();
  const int64_t rays = ResolveParams(opened->params, mesh.dimension).rays;
  ProgressBar bar(
      absl::StrCat("gradcheck: ", GradCheckPasses(mesh, options), " passes of ",
                   NumSamples(mesh, opened->params.samples) * rays, " rays"),
      in.out.Progress());
  auto rep = opened->backend->GradCheck(
      opened->params, options,
      bar.enabled() ? bar.Control() : ComputeControl{});
  bar.Finish();
  if (!rep.ok()) return rep.status();
  const int64_t samples = std::ssize(rep->rows);
  const GradCheckVerdict verdict = rep->Verdict();
  const bool passed = verdict == GradCheckVerdict::kPass;
  const char* verdict_name = passed ? "PASS"
                             : verdict == GradCheckVerdict::kFail
                                 ? "FAIL"
                                 : "INCONCLUSIVE";
  if (in.out.json) {
    nlohmann::json j;
    j["samples"] = samples;
    j["clean"] = rep->clean;
    j["passed_samples"] = rep->passed;
    j["worst_relative_error"] = rep->worst;
    j["vjp_checks"] = rep->vjp_checks;
    j["vjp_passed"] = rep->vjp_passed;
    j["penalty_clean"] = rep->penalty_clean;
    j["penalty_passed"] = rep->penalty_passed;
    j["max_abs_derivative"] = rep->max_abs_derivative;
    j["median_abs_derivative"] = rep->median_abs_derivative;
    j["world_frame_vertices"] = rep->world_frame_vertices;
    j["rays_traced"] = rep->rays_traced;
    j["full_pass_rays"] = rep->full_pass_rays;
    j["passed"] = passed;
    j["verdict"] = verdict_name;
    j["probe_repeats"] = rep->retried;
    j["rows"] = nlohmann::json::array();
    for (const auto* rows : {&rep->rows, &rep->penalty_rows}) {
      for (const GradCheckRow& r : *rows) j["rows"].push_back(RowJson(r));
    }
    j["vjp_rows"] = nlohmann::json::array();
    for (const GradCheckRow& r : rep->vjp_rows) {
      j["vjp_rows"].push_back(RowJson(r));
    }
    std::cout << j.dump() << "\n";
  } else {
    PrintTable(*rep, options.tolerance);
    std::cout << absl::StrFormat(
        "SDF entries: %d, clean %d (%.1f%%, need %.0f%%), within %.0e: %d, "
        "worst %.2e\nVJP checks: %d/%d\n",
        samples, rep->clean, 100.0 * rep->clean / std::max<int64_t>(1, samples),
        100 * options.min_clean_fraction, options.tolerance, rep->passed,
        rep->worst, rep->vjp_passed, rep->vjp_checks);
    if (options.penalty) {
      std::cout << absl::StrFormat(
          "penalty gradient: %d/%d clean within %.0e\n", rep->penalty_passed,
          rep->penalty_clean, options.tolerance);
    }
    std::cout << absl::StrFormat(
        "|dSDF/dx|: max %.4g, median %.4g; %d vertices in the world frame\n"
        "rays traced: %d (a full pass: %d; %s)\n"
        "probe repeats with a smaller step after an event: %d\n"
        "verdict: %s\n",
        rep->max_abs_derivative, rep->median_abs_derivative,
        rep->world_frame_vertices, rep->rays_traced, rep->full_pass_rays,
        // SdfEvaluator::Compute reuses rays of vertex samples only.
        opened->params.method != SdfMethod::kSphere &&
                opened->params.samples == SampleSet::kVertices
            ? "probes reuse the base pass"
            : "every probe is a full pass",
        rep->retried, verdict_name);
  }
  if (verdict == GradCheckVerdict::kFail) {
    return absl::FailedPreconditionError(
        "gradcheck failed: derivatives do not meet the SPEC §6 criterion");
  }
  if (verdict == GradCheckVerdict::kInconclusive) {
    return absl::FailedPreconditionError(absl::StrCat(
        "gradcheck inconclusive: ", rep->rows.size() - rep->clean, " of ",
        rep->rows.size(),
        " entries crossed an event even at a step 100 times smaller (listed "
        "as 'event'); every entry that could be checked agrees"));
  }
  return absl::OkStatus();
}

}  // namespace meshgauge::cli

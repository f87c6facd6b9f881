// meshgauge grad / penalty / calibrate.
#include <cmath>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/backend.h"
#include "client/cli/commands.h"
#include "client/cli/csv_io.h"
#include "client/cli/summary.h"
#include "client/cli/thin_summary.h"
#include "lib/core/face_sample.h"
#include "lib/core/missing_values.h"

namespace meshgauge::cli {

namespace {

// The pass's warnings (PassWarnings) as `sdf` gives them: on stderr, or
// with --json in the JSON only.
std::vector<std::string> ReportWarnings(const MeshInput& in,
                                        const Opened& opened,
                                        const SdfResult& result) {
  std::vector<std::string> warnings =
      PassWarnings(opened, result, in.out.warn_missing_fraction);
  if (!in.out.json) PrintWarnings(warnings);
  return warnings;
}

}  // namespace

absl::Status RunGrad(const MeshInput& in, const GradFlags& grad,
                     const BackendFactory& make) {
  auto opened = Open(in, make, /*print_warnings=*/false);  // with the pass's.
  if (!opened.ok()) return opened.status();
  Backend& backend = *opened->backend;
  // --weld: weights, the VJP and the Jacobian per input vertex.
  const Weld& weld = opened->loaded.weld;
  const bool per_vertex = opened->params.samples == SampleSet::kVertices;
  const Weld none;
  const Weld& input = per_vertex ? weld : none;
  const int64_t ns = input.welded_vertex.empty()
                         ? NumSamples(opened->mesh(), opened->params.samples)
                         : std::ssize(input.welded_vertex);
  const char* samples = SampleSetName(opened->params.samples);
  auto weights = ReadWeights(grad.weights, ns, samples);
  if (!weights.ok()) return weights.status();
  *weights = WeldWeights(input, std::move(*weights),
                         NumSamples(opened->mesh(), opened->params.samples));
  auto result = backend.Sdf(opened->params, grad.jacobian.empty()
                                                ? Derivatives::kVjp
                                                : Derivatives::kJacobian);
  if (!result.ok()) return result.status();
  // Derivatives of a surface mostly without values are refused, as a
  // penalty over it is (SPEC v2 §7), not written as zeros.
  const std::vector<std::string> warnings =
      ReportWarnings(in, *opened, *result);
  if (absl::Status s =
          CheckMissing(opened->mesh(), result->missing, result->Causes(),
                       grad.max_missing_fraction, "a gradient");
      !s.ok()) {
    return s;
  }
  nlohmann::json j;
  j["vertices"] = opened->mesh().num_vertices();
  j["samples"] = samples;
  j["sample_count"] = ns;
  j["ok"] = result->CountStatus(VertexStatus::kOk);
  if (const std::string& path = grad.jacobian; !path.empty()) {
    auto jac = backend.Jacobian();
    if (!jac.ok()) return jac.status();
    std::ofstream out(path);
    if (!out)
      return absl::InternalError(absl::StrCat("cannot write '", path, "'"));
    out << "row,col,dx,dy,dz\n";
    // Rows per input sample; columns are the vertices whose positions the
    // mesh kept (--weld: the lowest input vertex of each welded one).
    const std::vector<int32_t> column = KeptInputVertices(weld);
    const int64_t rows = std::ssize(jac->row_offsets) - 1;
    for (int64_t i = 0; i < (input.welded_vertex.empty() ? rows : ns); ++i) {
      const int64_t p = input.welded_vertex.empty() ? i : input.welded_vertex[i];
      for (int64_t e = jac->row_offsets[p]; e < jac->row_offsets[p + 1]; ++e) {
        const Vec3& d = jac->values[e];
        const int32_t c = jac->columns[e];
        out << absl::StrFormat("%d,%d,%.17g,%.17g,%.17g\n", i,
                               column.empty() ? c : column[c], d.x, d.y, d.z);
      }
    }
    if (!out)
      return absl::InternalError(absl::StrCat("error writing '", path, "'"));
    j["jacobian_nonzeros"] = jac->nonzeros();
  }
  auto vjp = backend.Vjp(*weights);
  if (!vjp.ok()) return vjp.status();
  *vjp = UnweldGradient(weld, *vjp);
  j["vjp_max_norm"] = MaxNorm(*vjp);
  j["missing_area_fraction"] = result->missing.area_fraction;
  j["warnings"] = warnings;
  if (const std::string& path = grad.vjp; !path.empty()) {
    if (absl::Status s = WriteVectorCsv(path, *vjp); !s.ok()) return s;
  }
  if (in.out.json) {
    std::cout << j.dump() << "\n";
  } else {
    std::cout << absl::StrFormat(
        "%s: %d (%d with a value)\nmax |g^T J| per vertex: %.6g\n", samples, ns,
        j["ok"].get<int64_t>(), j["vjp_max_norm"].get<double>());
    if (j.contains("jacobian_nonzeros")) {
      std::cout << "jacobian nonzeros: " << j["jacobian_nonzeros"] << "\n";
    }
  }
  return absl::OkStatus();
}

absl::Status RunPenalty(const MeshInput& in, const PenaltyFlags& flags,
                        const BackendFactory& make) {
  auto penalty = ToPenaltyParams(flags);
  if (!penalty.ok()) return penalty.status();
  const PenaltyParams& pp = *penalty;
  auto opened = Open(in, make, /*print_warnings=*/false);  // with the pass's.
  if (!opened.ok()) return opened.status();
  Backend& backend = *opened->backend;
  const std::string& grad_path = flags.grad;
  auto result =
      backend.Sdf(opened->params,
                  grad_path.empty() ? Derivatives::kNone : Derivatives::kVjp);
  if (!result.ok()) return result.status();
  const std::vector<std::string> warnings =
      ReportWarnings(in, *opened, *result);
  auto pen = backend.Penalty(*result, pp, !grad_path.empty());
  if (!pen.ok()) return pen.status();
  pen->gradient = UnweldGradient(opened->loaded.weld, pen->gradient);
  if (!grad_path.empty()) {
    if (absl::Status s = WriteVectorCsv(grad_path, pen->gradient); !s.ok())
      return s;
  }
  const bool ks = pp.form == PenaltyForm::kKs;
  nlohmann::json j;
  j[ks ? "constraint" : "penalty"] = pen->value;
  j["t_min"] = pp.t_min;
  j["form"] = PenaltyFormName(pp.form);
  if (ks) {
    j["rho"] = pp.rho;
  } else {
    j["power"] = pp.power;
  }
  j["samples"] = SampleSetName(opened->params.samples);
  j["skipped_faces"] = pen->missing.faces;
  j["missing_vertices"] = pen->missing.vertices;
  j["missing_area_fraction"] = pen->missing.area_fraction;
  j["world_frame_vertices"] = result->world_frame_vertices;
  if (!grad_path.empty()) j["gradient_max_norm"] = MaxNorm(pen->gradient);
  auto thin = FindThinRegions(
      opened->mesh(), result->values,
      {.t_min = pp.t_min, .samples = opened->params.samples});
  if (!thin.ok()) return thin.status();
  const std::string sentence =
      ThinSentence(*thin, opened->mesh().dimension == 2);
  j["thin"] = ThinJson(*thin);
  j["thin"].erase("regions");
  j["thin_regions"] = thin->regions.size();
  j["sentence"] = sentence;
  j["warnings"] = warnings;
  if (in.out.json) {
    std::cout << j.dump() << "\n";
    return absl::OkStatus();
  }
  if (ks) {
    std::cout << absl::StrFormat("constraint G = %.10g (ks, t_min %g, rho %g",
                                 pen->value, pp.t_min, pp.rho);
  } else {
    std::cout << absl::StrFormat("penalty P = %.10g (%s, t_min %g, n %g",
                                 pen->value, PenaltyFormName(pp.form), pp.t_min,
                                 pp.power);
  }
  if (opened->params.samples == SampleSet::kFaces) {
    std::cout << absl::StrFormat(
        "; face samples: %d faces without a value, %.2f%% of the area)\n",
        pen->missing.faces, 100 * pen->missing.area_fraction);
  } else {
    std::cout << absl::StrFormat(
        "; %d faces skipped, %.2f%% of the area, %d vertices without a "
        "value)\n",
        pen->missing.faces, 100 * pen->missing.area_fraction,
        pen->missing.vertices);
  }
  std::cout << sentence << "\n";
  return absl::OkStatus();
}

absl::Status RunCalibrate(const MeshInput& in, const CalibrateFlags& flags,
                          const BackendFactory& make) {
  auto opened = Open(in, make, /*print_warnings=*/true);
  if (!opened.ok()) return opened.status();
  CalibrationParams cp;
  cp.t_min = flags.t_min;
  cp.equal_tolerance = flags.tolerance;
  cp.bins = flags.bins;
  cp.sdf = opened->params;
  auto rep = opened->backend->Calibrate(cp);
  if (!rep.ok()) return rep.status();
  nlohmann::json j;
  j["compared"] = rep->compared;
  j["sdf_lower"] = rep->lower;
  j["sdf_equal"] = rep->equal;
  j["sdf_higher"] = rep->higher;
  j["equal_tolerance"] = cp.equal_tolerance;
  j["t_min"] = cp.t_min;
  j["alpha1"] = rep->alpha1;
  j["alpha2"] = rep->alpha2;
  j["histogram_range"] = {rep->sdf_histogram.lo, rep->sdf_histogram.hi};
  j["sdf_histogram"] = rep->sdf_histogram.counts;
  j["thickness_histogram"] = rep->thickness_histogram.counts;
  j["ball_compared"] = rep->ball_compared;
  j["ball_lower"] = rep->ball_lower;
  j["ball_equal"] = rep->ball_equal;
  j["ball_higher"] = rep->ball_higher;
  j["ball_alpha"] = rep->ball_alpha;
  j["ball_histogram"] = rep->ball_histogram.counts;
  if (in.out.json) {
    std::cout << j.dump() << "\n";
    return absl::OkStatus();
  }
  std::cout << absl::StrFormat(
      "vertices compared: %d\nSDF vs thickness (tolerance %g): %d lower, %d "
      "equal, %d higher\nalpha1 = max(thickness)/t_min = %.6g\nalpha2 = "
      "min(SDF)/t_min = %.6g\ninscribed ball vs thickness (%d vertices): %d "
      "lower, %d equal, %d higher; min(ball)/t_min = %.6g\n%-24s %8s %8s "
      "%8s\n",
      rep->compared, cp.equal_tolerance, rep->lower, rep->equal, rep->higher,
      rep->alpha1, rep->alpha2, rep->ball_compared, rep->ball_lower,
      rep->ball_equal, rep->ball_higher, rep->ball_alpha, "bin", "sdf", "thick",
      "ball");
  const Histogram& h = rep->sdf_histogram;
  for (size_t b = 0; b < h.counts.size(); ++b) {
    const double lo = h.lo + (h.hi - h.lo) * b / h.counts.size();
    const double hi = h.lo + (h.hi - h.lo) * (b + 1) / h.counts.size();
    std::cout << absl::StrFormat(
        "[%10.4g, %10.4g) %8d %8d %8d\n", lo, hi, h.counts[b],
        rep->thickness_histogram.counts[b], rep->ball_histogram.counts[b]);
  }
  return absl::OkStatus();
}

}  // namespace meshgauge::cli

#include "lib/penalty.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "lib/integrals.h"
#include "lib/sensitivity.h"

namespace meshgauge {
namespace {

struct Phi {
  PenaltyParams p;
  double Value(double t) const {
    if (p.form == PenaltyForm::kThesis)
      return std::pow(t / p.t_min - 1, p.power);
    return std::pow(std::max(0.0, 1 - t / p.t_min), p.power);
  }
  double Derivative(double t) const {
    if (p.form == PenaltyForm::kThesis) {
      return p.power * std::pow(t / p.t_min - 1, p.power - 1) / p.t_min;
    }
    const double base = 1 - t / p.t_min;
    if (base <= 0) return 0;
    return -p.power * std::pow(base, p.power - 1) / p.t_min;
  }
};

}  // namespace

absl::Status ValidatePenaltyParams(const PenaltyParams& p) {
  if (!(p.t_min > 0) || !std::isfinite(p.t_min)) {
    return absl::InvalidArgumentError(
        absl::StrCat("t_min must be a finite number > 0, got ", p.t_min));
  }
  if (!(p.power >= 1) || !std::isfinite(p.power)) {
    return absl::InvalidArgumentError(
        absl::StrCat("penalty power n must be >= 1, got ", p.power));
  }
  if (p.form == PenaltyForm::kThesis && p.power != std::floor(p.power)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the thesis penalty (t/t_min - 1)^n needs an integer n, got ",
        p.power));
  }
  return absl::OkStatus();
}

absl::StatusOr<PenaltyResult> ComputePenalty(const SdfEvaluator& evaluator,
                                             const std::vector<double>& values,
                                             const PenaltyParams& params,
                                             const HitTable* hits_for_gradient,
                                             const ComputeControl& control,
                                             int threads) {
  const bool with_gradient = hits_for_gradient != nullptr;
  if (absl::Status s = ValidatePenaltyParams(params); !s.ok()) return s;
  const Mesh& mesh = evaluator.mesh();
  if (std::ssize(values) != mesh.num_vertices()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "expected ", mesh.num_vertices(), " values, got ", values.size()));
  }
  const Phi phi{params};
  PenaltyResult r;
  r.dp_dt.assign(mesh.num_vertices(), 0.0);
  if (with_gradient) r.measure_gradient.assign(mesh.num_vertices(), Vec3());
  r.skipped_faces = ForEachValuedElement(
      mesh, values, [&](const Element& e, const double* t) {
        const auto& rule = QuadratureRule(e.n);
        double phi_sum = 0;
        for (size_t q = 0; q < rule.size(); ++q) {
          phi_sum += rule[q].weight * phi.Value(t[q]);
          const double dphi = rule[q].weight * e.measure * phi.Derivative(t[q]);
          for (int i = 0; i < e.n; ++i)
            r.dp_dt[e.v[i]] += dphi * rule[q].shape[i];
        }
        r.value += e.measure * phi_sum;
        if (with_gradient) {
          Vec3 grad[3];
          ElementMeasureGradient(mesh, e, grad);
          for (int i = 0; i < e.n; ++i) {
            r.measure_gradient[e.v[i]] += grad[i] * phi_sum;
          }
        }
      });
  if (!with_gradient) return r;
  auto vjp =
      ComputeVjp(evaluator, *hits_for_gradient, r.dp_dt, control, threads);
  if (!vjp.ok()) return vjp.status();
  r.gradient = std::move(*vjp);
  for (size_t i = 0; i < r.gradient.size(); ++i) {
    r.gradient[i] += r.measure_gradient[i];
  }
  return r;
}

}  // namespace meshgauge

#include "lib/core/penalty.h"

#include <cmath>
#include <functional>
#include <limits>

#include "absl/strings/str_cat.h"
#include "lib/core/face_sample.h"
#include "lib/core/exact_sum.h"
#include "lib/core/integrals.h"
#include "lib/core/sensitivity.h"

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

// I = integral of f(t) over the faces with values, with dI/dt_p (per
// sample) and (with `measure_terms`) the explicit dI/dx of the element
// measures: every sum over elements exact and rounded once (ExactSum), so
// that it does not depend on how the elements are visited or split.
struct NodalIntegral {
  double value = 0;
  std::vector<double> d_dt;
  std::vector<Vec3> d_measure;
};

// The exact sums of a NodalIntegral: x, y, z per vertex in d_measure.
struct NodalSums {
  NodalSums(int64_t samples, int64_t vertices, bool measure_terms)
      : d_dt(samples), d_measure(measure_terms ? 3 * vertices : 0) {}
  void AddMeasure(const Element& e, const Vec3 grad[3], double f) {
    for (int i = 0; i < e.n; ++i) {
      const Vec3 d = grad[i] * f;
      const int64_t m = 3 * int64_t{e.v[i]};
      d_measure.Add(m, d.x);
      d_measure.Add(m + 1, d.y);
      d_measure.Add(m + 2, d.z);
    }
  }
  NodalIntegral Round() const {
    NodalIntegral r;
    r.value = value.Round();
    r.d_dt.reserve(d_dt.size());
    for (int64_t i = 0; i < d_dt.size(); ++i) r.d_dt.push_back(d_dt.Round(i));
    r.d_measure = RoundVectors(d_measure);
    return r;
  }
  ExactSum value;
  ExactSums d_dt;
  ExactSums d_measure;
};

// Face samples (SPEC v2 §5c): t is constant on each face, so the integral
// is sum over faces of |f| f(t_f); faces without a value are skipped.
NodalIntegral IntegrateFaces(const Mesh& mesh,
                             const std::vector<double>& values,
                             const std::function<double(double)>& f,
                             const std::function<double(double)>& df,
                             bool measure_terms) {
  NodalSums r(mesh.num_faces(), mesh.num_vertices(), measure_terms);
  ForEachElement(mesh, [&](int64_t face, const Element& e) {
    const double t = values[face];
    if (!std::isfinite(t)) return;
    const double ft = f(t);
    r.value.Add(e.measure * ft);
    r.d_dt.Add(face, e.measure * df(t));
    if (measure_terms) {
      Vec3 grad[3];
      ElementMeasureGradient(mesh, e, grad);
      r.AddMeasure(e, grad, ft);
    }
  });
  return r.Round();
}

// Values per face (face samples) or per vertex, interpolated linearly.
NodalIntegral Integrate(const Mesh& mesh, const std::vector<double>& values,
                        bool faces, const std::function<double(double)>& f,
                        const std::function<double(double)>& df,
                        bool measure_terms) {
  if (faces) return IntegrateFaces(mesh, values, f, df, measure_terms);
  NodalSums r(mesh.num_vertices(), mesh.num_vertices(), measure_terms);
  ForEachValuedElement(mesh, values, [&](const Element& e, const double* t) {
    const auto& rule = QuadratureRule(e.n);
    double f_sum = 0;
    for (size_t q = 0; q < rule.size(); ++q) {
      f_sum += rule[q].weight * f(t[q]);
      const double dfq = rule[q].weight * e.measure * df(t[q]);
      for (int i = 0; i < e.n; ++i) r.d_dt.Add(e.v[i], dfq * rule[q].shape[i]);
    }
    r.value.Add(e.measure * f_sum);
    if (measure_terms) {
      Vec3 grad[3];
      ElementMeasureGradient(mesh, e, grad);
      r.AddMeasure(e, grad, f_sum);
    }
  });
  return r.Round();
}

// G = M + ln(I / A) / rho with I = integral of exp(rho (s - M)), s = 1 -
// t/t_min, M = max of s over the quadrature points (face samples: over the
// face values; no exp overflows, and I >= the weight of the point where
// s = M), A = |Gamma| of the valued faces. Values are per vertex, or per
// face (`faces`).
NodalIntegral KsConstraint(const Mesh& mesh, const std::vector<double>& values,
                           bool faces, const PenaltyParams& p,
                           bool measure_terms) {
  double shift = -std::numeric_limits<double>::infinity();
  if (faces) {
    for (double t : values) {
      if (std::isfinite(t)) shift = std::max(shift, 1 - t / p.t_min);
    }
  } else {
    ForEachValuedElement(mesh, values, [&](const Element& e, const double* t) {
      for (size_t q = 0; q < QuadratureRule(e.n).size(); ++q) {
        shift = std::max(shift, 1 - t[q] / p.t_min);
      }
    });
  }
  auto exp_s = [&](double t) {
    return std::exp(p.rho * ((1 - t / p.t_min) - shift));
  };
  const NodalIntegral ki = Integrate(
      mesh, values, faces, exp_s,
      [&](double t) { return -p.rho / p.t_min * exp_s(t); }, measure_terms);
  const NodalIntegral area = Integrate(
      mesh, values, faces, [](double) { return 1.0; }, [](double) { return 0.0; },
      measure_terms);
  NodalIntegral g;
  g.value = shift + std::log(ki.value / area.value) / p.rho;
  g.d_dt.resize(ki.d_dt.size());
  for (size_t i = 0; i < g.d_dt.size(); ++i) {
    g.d_dt[i] = ki.d_dt[i] / (p.rho * ki.value);
  }
  if (measure_terms) {
    g.d_measure.resize(ki.d_measure.size());
    for (size_t i = 0; i < g.d_measure.size(); ++i) {
      g.d_measure[i] =
          (ki.d_measure[i] / ki.value - area.d_measure[i] / area.value) / p.rho;
    }
  }
  return g;
}

}  // namespace

absl::Status ValidatePenaltyParams(const PenaltyParams& p) {
  if (!(p.t_min > 0) || !std::isfinite(p.t_min)) {
    return absl::InvalidArgumentError(
        absl::StrCat("t_min must be a finite number > 0, got ", p.t_min));
  }
  if (p.form != PenaltyForm::kKs &&
      (!(p.power >= 1) || !std::isfinite(p.power))) {
    return absl::InvalidArgumentError(
        absl::StrCat("penalty power n must be >= 1, got ", p.power));
  }
  if (p.form == PenaltyForm::kThesis && p.power != std::floor(p.power)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the thesis penalty (t/t_min - 1)^n needs an integer n, got ",
        p.power));
  }
  if (p.form == PenaltyForm::kKs && (!(p.rho > 0) || !std::isfinite(p.rho))) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the KS aggregation parameter rho must be a finite number > 0, got ",
        p.rho));
  }
  if (!(p.max_missing_fraction >= 0 && p.max_missing_fraction <= 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the allowed missing fraction must be in [0, 1], got ",
                     p.max_missing_fraction));
  }
  return absl::OkStatus();
}

const char* PenaltyFormName(PenaltyForm form) {
  switch (form) {
    case PenaltyForm::kOneSided:
      return "one-sided";
    case PenaltyForm::kThesis:
      return "thesis";
    case PenaltyForm::kKs:
      return "ks";
  }
  return "unknown";
}

absl::StatusOr<PenaltyResult> ComputePenalty(const MeshGeometry& geometry,
                                             const SdfResult& sdf,
                                             const PenaltyParams& params,
                                             const HitTable* hits_for_gradient,
                                             const ComputeControl& control) {
  const bool with_gradient = hits_for_gradient != nullptr;
  if (absl::Status s = ValidatePenaltyParams(params); !s.ok()) return s;
  const Mesh& mesh = geometry.mesh();
  const std::vector<double>& values = sdf.values;
  const bool faces = sdf.resolved.params.samples == SampleSet::kFaces;
  if (const int64_t n = NumSamples(mesh, sdf.resolved.params.samples);
      std::ssize(values) != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("expected ", n, " values (one per ",
                     faces ? "face" : "vertex", "), got ", values.size()));
  }
  PenaltyResult r;
  r.missing =
      faces ? CountMissingFaces(mesh, values) : CountMissing(mesh, values);
  const char* what = params.form == PenaltyForm::kKs ? "constraint" : "penalty";
  if (absl::Status s = CheckMissing(mesh, r.missing, sdf.Causes(),
                                    params.max_missing_fraction, what);
      !s.ok()) {
    return s;
  }
  if (r.missing.faces == mesh.num_faces()) {
    return absl::FailedPreconditionError(absl::StrCat(
        faces ? "no face has a value" : "no face has values at all its vertices",
        ": the ", what, " is undefined; ",
        LikelyMissingCause(mesh, sdf.Causes())));
  }
  NodalIntegral integral;
  if (params.form == PenaltyForm::kKs) {
    integral = KsConstraint(mesh, values, faces, params, with_gradient);
  } else {
    const Phi phi{params};
    integral = Integrate(
        mesh, values, faces, [&](double t) { return phi.Value(t); },
        [&](double t) { return phi.Derivative(t); }, with_gradient);
  }
  r.value = integral.value;
  r.dp_dt = std::move(integral.d_dt);
  if (!with_gradient) return r;
  r.measure_gradient = std::move(integral.d_measure);
  const SampleRange range = hits_for_gradient->resolved.params.range;
  absl::Span<const double> weights = r.dp_dt;
  if (!range.all()) {
    if (range.end > std::ssize(r.dp_dt)) {
      return absl::InvalidArgumentError(
          absl::StrCat("the hit table's range [", range.begin, ", ", range.end,
                       ") is past the ", r.dp_dt.size(), " samples"));
    }
    weights = weights.subspan(range.begin, range.end - range.begin);
  }
  auto sums = ComputeVjpSums(geometry, *hits_for_gradient, weights, control);
  if (!sums.ok()) return sums.status();
  if (range.all()) {
    r.gradient = PenaltyGradient(*sums, r.measure_gradient);
  } else {
    r.vjp_sums = std::move(*sums);
  }
  return r;
}

std::vector<Vec3> PenaltyGradient(const ExactSums& vjp_sums,
                                  absl::Span<const Vec3> measure_gradient) {
  std::vector<Vec3> gradient = RoundVectors(vjp_sums);
  for (size_t i = 0; i < gradient.size() && i < measure_gradient.size(); ++i) {
    gradient[i] += measure_gradient[i];
  }
  return gradient;
}

}  // namespace meshgauge

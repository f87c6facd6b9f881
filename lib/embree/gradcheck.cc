#include "lib/embree/gradcheck.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "absl/strings/str_cat.h"
#include "lib/core/face_sample.h"
#include "lib/core/sensitivity.h"
#include "lib/embree/sdf_evaluator.h"

namespace meshgauge {
namespace {

// Probes that crossed an event are repeated with steps 10 and 100 times
// smaller.
constexpr int kRetries = 2;

// One ray pass (and the penalty, when asked) at the evaluator's positions.
struct Pass {
  SdfResult sdf;
  HitTable hits;
  double penalty = 0;
};

// A probe's pass reuses the base pass's rays (`base`; only the rays the
// probed vertex can change are traced) where SdfEvaluator::Compute can:
// vertex samples with a ray method.
absl::StatusOr<Pass> Evaluate(const SdfEvaluator& ev, const SdfParams& params,
                              const GradCheckOptions& options,
                              const ComputeControl& control,
                              const Pass* base = nullptr) {
  Pass pass;
  const PreviousPass previous{base ? &base->sdf : nullptr,
                              base ? &base->hits : nullptr};
  auto r = ev.Compute(params, control, &pass.hits, &previous);
  if (!r.ok()) return r.status();
  pass.sdf = std::move(*r);
  if (options.penalty) {
    auto pen = ComputePenalty(ev, pass.sdf, *options.penalty, nullptr);
    if (!pen.ok()) return pen.status();
    pass.penalty = pen->value;
  }
  return pass;
}

// `control` without its progress: its threads and cancellation.
ComputeControl Quiet(const ComputeControl& control) {
  ComputeControl c;
  c.threads = control.threads;
  c.cancelled = control.cancelled;
  return c;
}

// The control of planned ray pass `index` of `passes`: its progress is
// reported as the whole check's (each pass counts its vertices). A repeated
// probe's pass (index -1) reports none, so progress never goes back.
ComputeControl PassControl(const ComputeControl& control, int64_t index,
                           int64_t passes) {
  ComputeControl c = Quiet(control);
  if (control.progress && index >= 0) {
    c.progress = [&control, index, passes](int64_t done, int64_t total) {
      control.progress(index * total + done, passes * total);
    };
  }
  return c;
}

bool SameRow(const HitTable& a, const HitTable& b, int64_t p) {
  const auto ra = a.Row(p), rb = b.Row(p);
  const auto ka = a.KeptRow(p), kb = b.KeptRow(p);
  return std::equal(ra.begin(), ra.end(), rb.begin()) &&
         std::equal(ka.begin(), ka.end(), kb.begin());
}

}  // namespace

absl::Status ValidateGradCheck(const Mesh& mesh, const SdfParams& params,
                               const GradCheckOptions& o) {
  if (absl::Status s = ValidateParams(params); !s.ok()) return s;
  // Face samples use each face's own normal whatever the weighting.
  if (params.normal_weighting != NormalWeighting::kArea &&
      params.samples == SampleSet::kVertices) {
    return absl::FailedPreconditionError(
        "gradcheck checks derivatives, which are only available with "
        "area-weighted normals (--normals area, the default)");
  }
  if (o.penalty) {
    if (absl::Status s = ValidatePenaltyParams(*o.penalty); !s.ok()) return s;
  }
  if (o.vertices.empty() && o.samples < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("gradcheck samples must be >= 1, got ", o.samples));
  }
  for (int32_t v : o.vertices) {
    if (v < 0 || v >= mesh.num_vertices()) {
      return absl::InvalidArgumentError(absl::StrCat("gradcheck vertex ", v,
                                                     " is out of range [0, ",
                                                     mesh.num_vertices(), ")"));
    }
  }
  if (!(o.relative_step > 0 && o.relative_step < 1e-2)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "gradcheck relative step must be in (0, 0.01), got ", o.relative_step));
  }
  if (!(o.tolerance > 0) || !(o.min_clean_fraction >= 0) ||
      !(o.min_clean_fraction <= 1)) {
    return absl::InvalidArgumentError(
        "gradcheck tolerance must be > 0 and the clean fraction in [0, 1]");
  }
  return absl::OkStatus();
}

int64_t GradCheckPasses(const Mesh& mesh, const GradCheckOptions& options) {
  int64_t probed = std::ssize(options.vertices);
  if (options.vertices.empty()) {
    std::vector<uint8_t> on_face(mesh.num_vertices(), 0);
    for (const Face& f : mesh.faces) {
      for (int k = 0; k < f.size; ++k) on_face[f.v[k]] = 1;
    }
    probed = std::min<int64_t>(options.samples,
                               std::count(on_face.begin(), on_face.end(), 1));
  }
  return 1 + 2 * mesh.dimension * probed;
}

namespace {

// The vertices to move: the explicit list, or `samples` distinct vertices
// with a face drawn with the seed.
std::vector<int32_t> PickVertices(const GradCheckOptions& o,
                                  const SdfEvaluator& ev) {
  if (!o.vertices.empty()) return o.vertices;
  std::vector<int32_t> candidates;
  for (int32_t v = 0; v < ev.mesh().num_vertices(); ++v) {
    if (!ev.topology().vertex_faces.Of(v).empty()) candidates.push_back(v);
  }
  std::mt19937_64 rng(o.seed);
  std::shuffle(candidates.begin(), candidates.end(), rng);
  candidates.resize(std::min<size_t>(candidates.size(), o.samples));
  std::sort(candidates.begin(), candidates.end());
  return candidates;
}

void SummarizeJacobian(const SparseJacobian& jac, GradCheckReport& rep) {
  std::vector<double> norms;
  norms.reserve(jac.values.size());
  for (const Vec3& d : jac.values) {
    if (Norm(d) > 0) norms.push_back(Norm(d));
  }
  if (norms.empty()) return;
  const size_t mid = norms.size() / 2;
  std::nth_element(norms.begin(), norms.begin() + mid, norms.end());
  rep.median_abs_derivative = norms[mid];
  rep.max_abs_derivative = *std::max_element(norms.begin(), norms.end());
}

}  // namespace

int64_t GradCheckWorkBytes(const Mesh& mesh, const SdfParams& params) {
  const int64_t rays = ResolveParams(params, mesh.dimension).rays;
  const int64_t pass = rays * 5 + 64;  // hit table and values, per sample.
  const int64_t jacobian = (2 * rays + 32) * (4 + 8 * 3) + 8;
  return NumSamples(mesh, params.samples) * (3 * pass + jacobian);
}

absl::StatusOr<GradCheckReport> RunGradCheck(const Mesh& mesh,
                                             const SdfParams& params,
                                             const GradCheckOptions& options,
                                             const ComputeControl& control) {
  // Refused before the BVH is built.
  if (absl::Status s = ValidateGradCheck(mesh, params, options); !s.ok()) {
    return s;
  }
  auto created = SdfEvaluator::Create(mesh);
  if (!created.ok()) return created.status();
  return RunGradCheck(**created, params, options, control);
}

namespace {

// The base pass and the derivatives every probe is compared with.
struct Derivatives {
  Pass base;
  SparseJacobian jac;
  std::vector<double> g;  // the VJP's weights, one per sample.
  std::vector<Vec3> vjp;  // g^T J.
  PenaltyResult pen;      // with options.penalty only.
};

// The base pass (planned pass 0 of `passes`) and its derivatives.
absl::StatusOr<Derivatives> BaseDerivatives(const SdfEvaluator& ev,
                                            const SdfParams& params,
                                            const GradCheckOptions& options,
                                            const ComputeControl& control,
                                            int64_t passes) {
  Derivatives d;
  auto base = Evaluate(ev, params, options, PassControl(control, 0, passes));
  if (!base.ok()) return base.status();
  d.base = std::move(*base);
  // The derivatives' own progress would restart the check's.
  const ComputeControl quiet = Quiet(control);
  auto jac = ComputeJacobian(ev, d.base.hits, quiet);
  if (!jac.ok()) return jac.status();
  d.jac = std::move(*jac);
  // Rows are samples: vertices or faces (SPEC v2 §5c); columns vertices.
  const int64_t ns = std::ssize(d.base.sdf.values);
  d.g.resize(ns);
  for (int64_t i = 0; i < ns; ++i) d.g[i] = std::sin(1.0 + 7.3 * i);
  auto vjp = ComputeVjp(ev, d.base.hits, d.g, quiet);
  if (!vjp.ok()) return vjp.status();
  d.vjp = std::move(*vjp);
  if (options.penalty) {
    auto p =
        ComputePenalty(ev, d.base.sdf, *options.penalty, &d.base.hits, quiet);
    if (!p.ok()) return p.status();
    d.pen = std::move(*p);
  }
  return d;
}

// What the probes of one check share.
struct Probing {
  SdfEvaluator& ev;
  const SdfParams& params;
  const GradCheckOptions& options;
  const ComputeControl& control;
  int64_t passes;  // planned ray passes, for progress.
  const Derivatives& d;
  double step;  // the first attempt's step: relative_step x diagonal.
};

absl::Status MoveVertex(SdfEvaluator& ev, int32_t j, const Vec3& x) {
  return ev.UpdatePositions(std::vector<int32_t>{j}, std::vector<Vec3>{x});
}

// The passes at x_j[c] + h (at[0]) and x_j[c] - h (at[1]); x_j is put back
// whatever happens. `planned`: the planned index of the first of the two
// passes, -1 for a repeat. Adds their rays to rep->rays_traced.
absl::Status ProbePasses(const Probing& pr, int32_t j, int c, double h,
                         int64_t planned, Pass at[2], GradCheckReport* rep) {
  const Vec3 x0 = pr.ev.mesh().positions[j];
  absl::Status status;
  for (int s = 0; s < 2 && status.ok(); ++s) {
    at[s] = Pass{};  // the previous attempt's pass goes first.
    Vec3 x = x0;
    x[c] += (s == 0 ? 1 : -1) * h;
    status = MoveVertex(pr.ev, j, x);
    if (!status.ok()) break;
    auto pass = Evaluate(
        pr.ev, pr.params, pr.options,
        PassControl(pr.control, planned < 0 ? -1 : planned + s, pr.passes),
        &pr.d.base);
    if (!pass.ok()) {
      status = pass.status();
      break;
    }
    rep->rays_traced += pass->sdf.rays_traced;
    at[s] = std::move(*pass);
  }
  absl::Status restored = MoveVertex(pr.ev, j, x0);
  return status.ok() ? restored : status;
}

// The Jacobian rows of one probed coordinate over its attempts: each sample
// keeps its first clean attempt.
struct ProbeRows {
  std::vector<GradCheckRow> rows;
  std::vector<int64_t> row_of;  // per sample: its index in rows, or -1.
};

// One attempt's comparison of the Jacobian with the finite differences.
struct AttemptSums {
  bool all_clean = true;
  double fd_dot = 0;     // g . (the clean finite differences)
  double g_squares = 0;  // |g|^2 over the clean samples
};

// Compares column (j, c) of the Jacobian with the central differences of
// `at` at step h, sample by sample, into `rows`.
AttemptSums CompareSamples(const Probing& pr, int32_t j, int c, double h,
                           const Pass at[2], ProbeRows* rows) {
  const SparseJacobian& jac = pr.d.jac;
  const Pass& base = pr.d.base;
  AttemptSums sums;
  for (int64_t p = 0; p < std::ssize(rows->row_of); ++p) {
    GradCheckRow row{static_cast<int32_t>(p), j, c};
    for (int64_t e = jac.row_offsets[p]; e < jac.row_offsets[p + 1]; ++e) {
      if (jac.columns[e] == j) row.analytic = jac.values[e][c];
    }
    const double plus = at[0].sdf.values[p], minus = at[1].sdf.values[p];
    const bool finite = std::isfinite(plus) && std::isfinite(minus) &&
                        std::isfinite(base.sdf.values[p]);
    row.fd = finite ? (plus - minus) / (2 * h) : 0;
    row.step = h;
    if (row.analytic == 0 && (row.fd == 0 || !finite)) continue;
    row.clean = finite && SameRow(base.hits, at[0].hits, p) &&
                SameRow(base.hits, at[1].hits, p);
    sums.all_clean &= row.clean;
    if (row.clean) {
      sums.fd_dot += pr.d.g[p] * row.fd;
      sums.g_squares += pr.d.g[p] * pr.d.g[p];
      row.relative_error = GradCheckRelativeError(row.fd, row.analytic,
                                                  GradCheckFloor(pr.step, h));
    }
    int64_t& index = rows->row_of[p];
    if (index < 0) {
      index = std::ssize(rows->rows);
      rows->rows.push_back(row);
    } else if (!rows->rows[index].clean && row.clean) {
      rows->rows[index] = row;
    }
  }
  return sums;
}

// The VJP's entry (j, c) against the clean finite differences of an
// attempt at step h.
void AddVjpRow(const Probing& pr, int32_t j, int c, double h,
               const AttemptSums& sums, GradCheckReport* rep) {
  GradCheckRow row{-1, j, c};
  row.analytic = pr.d.vjp[j][c];
  row.fd = sums.fd_dot;
  row.step = h;
  row.clean = true;
  row.relative_error = GradCheckRelativeError(
      sums.fd_dot, row.analytic,
      GradCheckFloor(pr.step, h, std::sqrt(sums.g_squares)));
  ++rep->vjp_checks;
  rep->vjp_passed += row.relative_error <= pr.options.tolerance;
  rep->vjp_rows.push_back(row);
}

// The penalty gradient's entry (j, c) against the central difference of
// the penalties of `at` at step h.
void AddPenaltyRow(const Probing& pr, int32_t j, int c, double h,
                   const Pass at[2], GradCheckReport* rep) {
  const HitTable& base = pr.d.base.hits;
  GradCheckRow row{-1, j, c};
  row.analytic = pr.d.pen.gradient[j][c];
  row.measure_part = pr.d.pen.measure_gradient[j][c];
  row.fd = (at[0].penalty - at[1].penalty) / (2 * h);
  row.step = h;
  row.clean = base.primitives == at[0].hits.primitives &&
              base.primitives == at[1].hits.primitives &&
              base.kept == at[0].hits.kept && base.kept == at[1].hits.kept;
  if (row.analytic == 0 && row.fd == 0) return;
  row.relative_error = GradCheckRelativeError(row.fd, row.analytic);
  if (row.clean) {
    ++rep->penalty_clean;
    rep->penalty_passed += row.relative_error <= pr.options.tolerance;
  }
  rep->penalty_rows.push_back(row);
}

// Probes coordinate c of vertex j (planned passes `planned` and the next).
// Entries whose probe crossed an event are probed again with steps 10 and
// 100 times smaller; each keeps its first clean attempt.
absl::Status CheckCoordinate(const Probing& pr, int32_t j, int c,
                             int64_t planned, GradCheckReport* rep) {
  ProbeRows rows;
  rows.row_of.assign(pr.d.base.sdf.values.size(), -1);
  bool vjp_done = false;
  Pass at[2];
  for (int attempt = 0; attempt <= kRetries; ++attempt) {
    const double h = pr.step * std::pow(0.1, attempt);
    if (absl::Status st =
            ProbePasses(pr, j, c, h, attempt == 0 ? planned : -1, at, rep);
        !st.ok()) {
      return st;
    }
    const AttemptSums sums = CompareSamples(pr, j, c, h, at, &rows);
    if (sums.all_clean && !vjp_done) {
      vjp_done = true;
      AddVjpRow(pr, j, c, h, sums, rep);
    }
    if (attempt == 0 && pr.options.penalty) {
      AddPenaltyRow(pr, j, c, h, at, rep);
    }
    if (sums.all_clean) break;
    rep->retried += attempt < kRetries;
  }
  for (const GradCheckRow& row : rows.rows) {
    if (row.clean) {
      ++rep->clean;
      rep->passed += row.relative_error <= pr.options.tolerance;
      rep->worst = std::max(rep->worst, row.relative_error);
    }
    rep->rows.push_back(row);
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<GradCheckReport> RunGradCheck(SdfEvaluator& ev,
                                             const SdfParams& params,
                                             const GradCheckOptions& options,
                                             const ComputeControl& control) {
  const Mesh& mesh = ev.mesh();
  if (absl::Status s = ValidateGradCheck(mesh, params, options); !s.ok()) {
    return s;
  }
  const std::vector<int32_t> probed = PickVertices(options, ev);
  const int64_t passes = GradCheckPasses(mesh, options);
  auto d = BaseDerivatives(ev, params, options, control, passes);
  if (!d.ok()) return d.status();
  GradCheckReport rep;
  rep.min_clean_fraction = options.min_clean_fraction;
  rep.rays_traced = d->base.sdf.rays_traced;
  rep.full_pass_rays = d->base.sdf.rays_traced;
  rep.world_frame_vertices = d->base.sdf.world_frame_vertices;
  SummarizeJacobian(d->jac, rep);
  const Probing pr{ev,
                   params,
                   options,
                   control,
                   passes,
                   *d,
                   options.relative_step * BoundingBoxDiagonal(mesh)};
  int64_t next_planned = 1;  // the base pass is 0.
  for (int32_t j : probed) {
    for (int c = 0; c < mesh.dimension; ++c, next_planned += 2) {
      if (absl::Status s = CheckCoordinate(pr, j, c, next_planned, &rep);
          !s.ok()) {
        return s;
      }
    }
  }
  return rep;
}

}  // namespace meshgauge

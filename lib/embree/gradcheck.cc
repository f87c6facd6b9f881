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

// The control of planned ray pass `index` of `passes`: its progress is
// reported as the whole check's (each pass counts its vertices). A repeated
// probe's pass (index -1) reports none, so progress never goes back.
ComputeControl PassControl(const ComputeControl& control, int64_t index,
                           int64_t passes) {
  ComputeControl c;
  c.cancelled = control.cancelled;
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
  auto base = Evaluate(ev, params, options, PassControl(control, 0, passes));
  if (!base.ok()) return base.status();
  // The derivatives' own progress would restart the check's.
  ComputeControl quiet;
  quiet.cancelled = control.cancelled;
  auto jac = ComputeJacobian(ev, base->hits, quiet, params.threads);
  if (!jac.ok()) return jac.status();
  // Rows are samples: vertices or faces (SPEC v2 §5c); columns vertices.
  const int64_t ns = std::ssize(base->sdf.values);
  std::vector<double> g(ns);
  for (int64_t i = 0; i < ns; ++i) g[i] = std::sin(1.0 + 7.3 * i);
  auto vjp = ComputeVjp(ev, base->hits, g, quiet, params.threads);
  if (!vjp.ok()) return vjp.status();
  PenaltyResult pen;
  if (options.penalty) {
    auto p = ComputePenalty(ev, base->sdf, *options.penalty, &base->hits, quiet,
                            params.threads);
    if (!p.ok()) return p.status();
    pen = std::move(*p);
  }

  GradCheckReport rep;
  rep.min_clean_fraction = options.min_clean_fraction;
  rep.rays_traced = base->sdf.rays_traced;
  rep.full_pass_rays = base->sdf.rays_traced;
  rep.world_frame_vertices = base->sdf.world_frame_vertices;
  SummarizeJacobian(*jac, rep);
  const double step = options.relative_step * BoundingBoxDiagonal(mesh);
  auto move = [&ev](int32_t j, const Vec3& x) {
    return ev.UpdatePositions(std::vector<int32_t>{j}, std::vector<Vec3>{x});
  };
  // The passes at x_j[c] +- h; x_j is put back whatever happens.
  // `planned`: the planned index of the first of the two passes, -1 for a
  // repeat.
  auto probe = [&](int32_t j, int c, double h, int64_t planned,
                   Pass at[2]) -> absl::Status {
    const Vec3 x0 = mesh.positions[j];
    absl::Status status;
    for (int s = 0; s < 2 && status.ok(); ++s) {
      at[s] = Pass{};  // the previous attempt's pass goes first.
      Vec3 x = x0;
      x[c] += (s == 0 ? 1 : -1) * h;
      status = move(j, x);
      if (!status.ok()) break;
      auto pass = Evaluate(
          ev, params, options,
          PassControl(control, planned < 0 ? -1 : planned + s, passes), &*base);
      if (!pass.ok()) {
        status = pass.status();
        break;
      }
      rep.rays_traced += pass->sdf.rays_traced;
      at[s] = std::move(*pass);
    }
    absl::Status restored = move(j, x0);
    return status.ok() ? restored : status;
  };
  int64_t next_planned = 1;  // the base pass is 0.
  for (int32_t j : probed) {
    for (int c = 0; c < mesh.dimension; ++c, next_planned += 2) {
      // Entries whose probe crossed an event are probed again with steps 10
      // and 100 times smaller; each keeps its first clean attempt.
      std::vector<GradCheckRow> rows;
      std::vector<int64_t> row_of(ns, -1);
      bool vjp_done = false;
      Pass at[2];
      for (int attempt = 0; attempt <= kRetries; ++attempt) {
        const double h = step * std::pow(0.1, attempt);
        if (absl::Status st =
                probe(j, c, h, attempt == 0 ? next_planned : -1, at);
            !st.ok()) {
          return st;
        }
        bool all_clean = true;
        double fd_dot = 0, g_squares = 0;
        for (int64_t p = 0; p < ns; ++p) {
          GradCheckRow row{static_cast<int32_t>(p), j, c};
          for (int64_t e = jac->row_offsets[p]; e < jac->row_offsets[p + 1];
               ++e) {
            if (jac->columns[e] == j) row.analytic = jac->values[e][c];
          }
          const double plus = at[0].sdf.values[p], minus = at[1].sdf.values[p];
          const bool finite = std::isfinite(plus) && std::isfinite(minus) &&
                              std::isfinite(base->sdf.values[p]);
          row.fd = finite ? (plus - minus) / (2 * h) : 0;
          row.step = h;
          if (row.analytic == 0 && (row.fd == 0 || !finite)) continue;
          row.clean = finite && SameRow(base->hits, at[0].hits, p) &&
                      SameRow(base->hits, at[1].hits, p);
          all_clean &= row.clean;
          if (row.clean) {
            fd_dot += g[p] * row.fd;
            g_squares += g[p] * g[p];
            row.relative_error = GradCheckRelativeError(
                row.fd, row.analytic, GradCheckFloor(step, h));
          }
          if (row_of[p] < 0) {
            row_of[p] = std::ssize(rows);
            rows.push_back(row);
          } else if (!rows[row_of[p]].clean && row.clean) {
            rows[row_of[p]] = row;
          }
        }
        if (all_clean && !vjp_done) {
          vjp_done = true;
          GradCheckRow row{-1, j, c};
          row.analytic = (*vjp)[j][c];
          row.fd = fd_dot;
          row.step = h;
          row.clean = true;
          row.relative_error = GradCheckRelativeError(
              fd_dot, row.analytic,
              GradCheckFloor(step, h, std::sqrt(g_squares)));
          ++rep.vjp_checks;
          rep.vjp_passed += row.relative_error <= options.tolerance;
          rep.vjp_rows.push_back(row);
        }
        if (attempt == 0 && options.penalty) {
          GradCheckRow row{-1, j, c};
          row.analytic = pen.gradient[j][c];
          row.measure_part = pen.measure_gradient[j][c];
          row.fd = (at[0].penalty - at[1].penalty) / (2 * h);
          row.step = h;
          row.clean = base->hits.primitives == at[0].hits.primitives &&
                      base->hits.primitives == at[1].hits.primitives &&
                      base->hits.kept == at[0].hits.kept &&
                      base->hits.kept == at[1].hits.kept;
          if (row.analytic != 0 || row.fd != 0) {
            row.relative_error = GradCheckRelativeError(row.fd, row.analytic);
            if (row.clean) {
              ++rep.penalty_clean;
              rep.penalty_passed += row.relative_error <= options.tolerance;
            }
            rep.penalty_rows.push_back(row);
          }
        }
        if (all_clean) break;
        rep.retried += attempt < kRetries;
      }
      for (const GradCheckRow& row : rows) {
        if (row.clean) {
          ++rep.clean;
          rep.passed += row.relative_error <= options.tolerance;
          rep.worst = std::max(rep.worst, row.relative_error);
        }
        rep.rows.push_back(row);
      }
    }
  }
  return rep;
}

}  // namespace meshgauge

#include "proto/wire/gradcheck_convert.h"

#include "absl/strings/str_cat.h"
#include "proto/wire/convert.h"

namespace meshgauge::wire {
namespace {

constexpr int kDefaultSamples = 12;
constexpr uint64_t kDefaultSeed = 1;
constexpr double kDefaultStep = 1e-7;
constexpr double kDefaultTolerance = 1e-5;

v1::GradCheckVerdict ToWire(GradCheckVerdict v) {
  switch (v) {
    case GradCheckVerdict::kPass:
      return v1::GRAD_CHECK_VERDICT_PASS;
    case GradCheckVerdict::kFail:
      return v1::GRAD_CHECK_VERDICT_FAIL;
    case GradCheckVerdict::kInconclusive:
      return v1::GRAD_CHECK_VERDICT_INCONCLUSIVE;
  }
  return v1::GRAD_CHECK_VERDICT_UNSPECIFIED;
}

void RowToWire(const GradCheckRow& r, v1::GradCheckRow* out) {
  out->set_row(r.row);
  out->set_vertex(r.vertex);
  out->set_coordinate(r.coordinate);
  out->set_analytic(r.analytic);
  out->set_fd(r.fd);
  out->set_relative_error(r.relative_error);
  out->set_clean(r.clean);
  out->set_step(r.step);
  out->set_measure_part(r.measure_part);
}

absl::StatusOr<GradCheckRow> RowFromWire(const v1::GradCheckRow& r) {
  if (r.coordinate() < 0 || r.coordinate() > 2) {
    return absl::DataLossError(absl::StrCat(
        "gradcheck row with coordinate ", r.coordinate(), " (not 0, 1 or 2)"));
  }
  GradCheckRow row;
  row.row = r.row();
  row.vertex = r.vertex();
  row.coordinate = r.coordinate();
  row.analytic = r.analytic();
  row.fd = r.fd();
  row.relative_error = r.relative_error();
  row.clean = r.clean();
  row.step = r.step();
  row.measure_part = r.measure_part();
  return row;
}

}  // namespace

void ToWire(const GradCheckOptions& o, v1::GradCheckRequest* out) {
  out->set_samples(o.samples);
  out->set_seed(o.seed);
  out->mutable_vertices()->Assign(o.vertices.begin(), o.vertices.end());
  out->set_relative_step(o.relative_step);
  out->set_tolerance(o.tolerance);
  out->set_min_clean_fraction(o.min_clean_fraction);
  if (o.penalty) ToWire(*o.penalty, out->mutable_penalty());
}

absl::StatusOr<GradCheckOptions> GradCheckFromWire(
    const v1::GradCheckRequest& r) {
  GradCheckOptions o;
  o.samples = r.samples() == 0 ? kDefaultSamples : r.samples();
  if (o.samples < 1 || o.samples > kMaxGradCheckVertices) {
    return absl::InvalidArgumentError(
        absl::StrCat("samples must be in [1, ", kMaxGradCheckVertices,
                     "] (0 = ", kDefaultSamples, "), got ", r.samples()));
  }
  if (r.vertices_size() > kMaxGradCheckVertices) {
    return absl::InvalidArgumentError(
        absl::StrCat("vertices lists ", r.vertices_size(),
                     " vertices, more than ", kMaxGradCheckVertices));
  }
  o.seed = r.has_seed() ? r.seed() : kDefaultSeed;
  o.vertices.assign(r.vertices().begin(), r.vertices().end());
  o.relative_step = r.relative_step() == 0 ? kDefaultStep : r.relative_step();
  o.tolerance = r.tolerance() == 0 ? kDefaultTolerance : r.tolerance();
  if (r.has_min_clean_fraction()) {
    o.min_clean_fraction = r.min_clean_fraction();
  }
  if (r.has_penalty()) {
    auto penalty = PenaltyFromWire(r.penalty());
    if (!penalty.ok()) return penalty.status();
    o.penalty = *penalty;
  }
  return o;
}

void ToWire(const GradCheckReport& r, int64_t generation,
            v1::GradCheckReport* out) {
  out->set_generation(generation);
  out->set_verdict(ToWire(r.Verdict()));
  for (const GradCheckRow& row : r.rows) RowToWire(row, out->add_rows());
  for (const GradCheckRow& row : r.penalty_rows) {
    RowToWire(row, out->add_penalty_rows());
  }
  for (const GradCheckRow& row : r.vjp_rows) {
    RowToWire(row, out->add_vjp_rows());
  }
  out->set_clean(r.clean);
  out->set_passed(r.passed);
  out->set_worst(r.worst);
  out->set_vjp_checks(r.vjp_checks);
  out->set_vjp_passed(r.vjp_passed);
  out->set_penalty_clean(r.penalty_clean);
  out->set_penalty_passed(r.penalty_passed);
  out->set_max_abs_derivative(r.max_abs_derivative);
  out->set_median_abs_derivative(r.median_abs_derivative);
  out->set_world_frame_vertices(r.world_frame_vertices);
  out->set_min_clean_fraction(r.min_clean_fraction);
  out->set_rays_traced(r.rays_traced);
  out->set_full_pass_rays(r.full_pass_rays);
  out->set_probe_repeats(r.retried);
}

absl::StatusOr<GradCheckReport> FromWire(const v1::GradCheckReport& r) {
  GradCheckReport rep;
  for (const auto& [rows, into] :
       {std::pair{&r.rows(), &rep.rows},
        std::pair{&r.penalty_rows(), &rep.penalty_rows},
        std::pair{&r.vjp_rows(), &rep.vjp_rows}}) {
    for (const v1::GradCheckRow& w : *rows) {
      auto row = RowFromWire(w);
      if (!row.ok()) return row.status();
      into->push_back(*row);
    }
  }
  rep.clean = r.clean();
  rep.passed = r.passed();
  rep.worst = r.worst();
  rep.vjp_checks = r.vjp_checks();
  rep.vjp_passed = r.vjp_passed();
  rep.penalty_clean = r.penalty_clean();
  rep.penalty_passed = r.penalty_passed();
  rep.max_abs_derivative = r.max_abs_derivative();
  rep.median_abs_derivative = r.median_abs_derivative();
  rep.world_frame_vertices = r.world_frame_vertices();
  rep.min_clean_fraction = r.min_clean_fraction();
  rep.rays_traced = r.rays_traced();
  rep.full_pass_rays = r.full_pass_rays();
  rep.retried = r.probe_repeats();
  if (ToWire(rep.Verdict()) != r.verdict()) {
    return absl::DataLossError(absl::StrCat(
        "gradcheck report's verdict ", v1::GradCheckVerdict_Name(r.verdict()),
        " does not follow from its counts"));
  }
  return rep;
}

}  // namespace meshgauge::wire

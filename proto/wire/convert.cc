#include "proto/wire/convert.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "absl/strings/str_cat.h"

namespace meshgauge::wire {
namespace {

absl::Status Malformed(absl::string_view what) {
  return absl::DataLossError(
      absl::StrCat("malformed ComputeSdf reply: ", what));
}

// ComputePenaltyRequest and PenaltyParameters share these fields.
template <typename Message>
void PenaltyToMessage(const PenaltyParams& p, Message* out) {
  out->set_t_min(p.t_min);
  switch (p.form) {
    case PenaltyForm::kOneSided:
      out->set_form(v1::PENALTY_FORM_ONE_SIDED);
      break;
    case PenaltyForm::kThesis:
      out->set_form(v1::PENALTY_FORM_THESIS);
      break;
    case PenaltyForm::kKs:
      out->set_form(v1::PENALTY_FORM_KS);
      break;
  }
  out->set_power(p.power);
  out->set_rho(p.rho);
  out->set_max_missing_fraction(p.max_missing_fraction);
}

template <typename Message>
absl::StatusOr<PenaltyParams> PenaltyFromMessage(const Message& r) {
  PenaltyParams p;
  p.t_min = r.t_min();
  p.power = r.power() == 0 ? 2.0 : r.power();
  if (r.rho() != 0) p.rho = r.rho();
  if (r.has_max_missing_fraction()) {
    p.max_missing_fraction = r.max_missing_fraction();
  }
  switch (r.form()) {
    case v1::PENALTY_FORM_UNSPECIFIED:
    case v1::PENALTY_FORM_ONE_SIDED:
      p.form = PenaltyForm::kOneSided;
      break;
    case v1::PENALTY_FORM_THESIS:
      p.form = PenaltyForm::kThesis;
      break;
    case v1::PENALTY_FORM_KS:
      p.form = PenaltyForm::kKs;
      break;
    default:
      return absl::InvalidArgumentError(absl::StrCat(
          "form ", static_cast<int>(r.form()), " is not a known PenaltyForm"));
  }
  if (absl::Status s = ValidatePenaltyParams(p); !s.ok()) return s;
  return p;
}

}  // namespace

v1::SdfParameters ToWire(const SdfParams& p) {
  v1::SdfParameters w;
  switch (p.method) {
    case SdfMethod::kCone:
      w.set_method(v1::SDF_METHOD_CONE);
      break;
    case SdfMethod::kNormalRay:
      w.set_method(v1::SDF_METHOD_NORMAL_RAY);
      break;
    case SdfMethod::kSphere:
      w.set_method(v1::SDF_METHOD_SPHERE);
      break;
  }
  w.set_contact_angle_degrees(p.contact_angle_degrees);
  w.set_opposite_points(p.opposite_points);
  w.set_samples(p.samples == SampleSet::kFaces ? v1::SAMPLE_SET_FACES
                                               : v1::SAMPLE_SET_VERTICES);
  w.set_cone_angle_degrees(p.cone_angle_degrees);
  w.set_rays(p.rays);
  w.set_kappa(p.kappa);
  w.set_min_weight_angle(p.min_weight_angle);
  w.set_max_distance(p.max_distance);
  w.set_self_hit_epsilon(p.self_hit_epsilon);
  w.set_normal_weighting(p.normal_weighting == NormalWeighting::kAngle
                             ? v1::NORMAL_WEIGHTING_ANGLE
                             : v1::NORMAL_WEIGHTING_AREA);
  return w;
}

absl::StatusOr<SdfParams> FromWire(const v1::SdfParameters& p,
                                   int max_rays) {
  SdfParams out;
  switch (p.method()) {
    case v1::SDF_METHOD_UNSPECIFIED:
    case v1::SDF_METHOD_CONE:
      out.method = SdfMethod::kCone;
      break;
    case v1::SDF_METHOD_NORMAL_RAY:
      out.method = SdfMethod::kNormalRay;
      break;
    case v1::SDF_METHOD_SPHERE:
      out.method = SdfMethod::kSphere;
      break;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("params.method ", static_cast<int>(p.method()),
                       " is not a known SdfMethod"));
  }
  switch (p.normal_weighting()) {
    case v1::NORMAL_WEIGHTING_UNSPECIFIED:
    case v1::NORMAL_WEIGHTING_AREA:
      out.normal_weighting = NormalWeighting::kArea;
      break;
    case v1::NORMAL_WEIGHTING_ANGLE:
      out.normal_weighting = NormalWeighting::kAngle;
      break;
    default:
      return absl::InvalidArgumentError(absl::StrCat(
          "params.normal_weighting ", static_cast<int>(p.normal_weighting()),
          " is not a known NormalWeighting"));
  }
  switch (p.samples()) {
    case v1::SAMPLE_SET_UNSPECIFIED:
    case v1::SAMPLE_SET_VERTICES:
      out.samples = SampleSet::kVertices;
      break;
    case v1::SAMPLE_SET_FACES:
      out.samples = SampleSet::kFaces;
      break;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("params.samples ", static_cast<int>(p.samples()),
                       " is not a known SampleSet"));
  }
  if (p.cone_angle_degrees() != 0)
    out.cone_angle_degrees = p.cone_angle_degrees();
  if (p.contact_angle_degrees() != 0) {
    out.contact_angle_degrees = p.contact_angle_degrees();
  }
  out.opposite_points = p.opposite_points();
  out.rays = p.rays();
  if (p.has_kappa()) out.kappa = p.kappa();
  out.min_weight_angle = p.min_weight_angle();
  out.max_distance = p.max_distance();
  if (p.self_hit_epsilon() != 0) out.self_hit_epsilon = p.self_hit_epsilon();
  if (out.method == SdfMethod::kCone && p.rays() > max_rays) {
    return absl::InvalidArgumentError(absl::StrCat(
        "params.rays ", p.rays(), " exceeds the server's limit of ", max_rays,
        " rays per vertex (--max_rays)"));
  }
  if (absl::Status s = ValidateParams(out); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("params: ", s.message()));
  }
  return out;
}

void ToWire(const PenaltyParams& p, v1::ComputePenaltyRequest* out) {
  PenaltyToMessage(p, out);
}

void ToWire(const PenaltyParams& p, v1::PenaltyParameters* out) {
  PenaltyToMessage(p, out);
}

absl::StatusOr<std::optional<ThinRequest>> ThinFromWire(
    const v1::ComputePenaltyRequest& r) {
  if (!r.with_thin_regions()) return std::nullopt;
  ThinRequest t;
  t.params.t_min = r.t_min();
  t.params.min_region_area = r.min_region_area();
  if (!(t.params.min_region_area >= 0) ||
      !std::isfinite(t.params.min_region_area)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "min_region_area must be >= 0 and finite, got ", r.min_region_area()));
  }
  if (r.max_thin_regions() < 0 || r.max_thin_regions() > 100000) {
    return absl::InvalidArgumentError(absl::StrCat(
        "max_thin_regions must be in 0..100000, got ", r.max_thin_regions()));
  }
  if (r.max_thin_regions() > 0) t.max_regions = r.max_thin_regions();
  return t;
}

absl::StatusOr<PenaltyParams> PenaltyFromWire(
    const v1::ComputePenaltyRequest& r) {
  return PenaltyFromMessage(r);
}

absl::StatusOr<PenaltyParams> PenaltyFromWire(const v1::PenaltyParameters& r) {
  return PenaltyFromMessage(r);
}

void ToWire(const CalibrationParams& p, v1::CalibrateRequest* out) {
  *out->mutable_params() = ToWire(p.sdf);
  out->set_t_min(p.t_min);
  out->set_equal_tolerance(p.equal_tolerance);
  out->set_bins(p.bins);
}

CalibrationParams CalibrationFromWire(const v1::CalibrateRequest& r,
                                      const SdfParams& sdf) {
  CalibrationParams p;
  p.t_min = r.t_min();
  if (r.equal_tolerance() != 0) p.equal_tolerance = r.equal_tolerance();
  if (r.bins() != 0) p.bins = r.bins();
  p.sdf = sdf;
  return p;
}

v1::VertexStatus ToWire(VertexStatus s) {
  switch (s) {
    case VertexStatus::kOk:
      return v1::VERTEX_STATUS_OK;
    case VertexStatus::kNoHit:
      return v1::VERTEX_STATUS_NO_HIT;
    case VertexStatus::kNoFaces:
      return v1::VERTEX_STATUS_NO_FACES;
    case VertexStatus::kDegenerateNormal:
      return v1::VERTEX_STATUS_DEGENERATE_NORMAL;
  }
  return v1::VERTEX_STATUS_UNSPECIFIED;
}

absl::StatusOr<VertexStatus> FromWire(v1::VertexStatus s) {
  switch (s) {
    case v1::VERTEX_STATUS_OK:
      return VertexStatus::kOk;
    case v1::VERTEX_STATUS_NO_HIT:
      return VertexStatus::kNoHit;
    case v1::VERTEX_STATUS_NO_FACES:
      return VertexStatus::kNoFaces;
    case v1::VERTEX_STATUS_DEGENERATE_NORMAL:
      return VertexStatus::kDegenerateNormal;
    default:
      return absl::DataLossError(absl::StrCat(
          "vertex status ", static_cast<int>(s), " is not a known one"));
  }
}

v1::ConeDirection ToWire(ConeDirection d) {
  return d == ConeDirection::kOutward ? v1::CONE_DIRECTION_OUTWARD
                                      : v1::CONE_DIRECTION_INWARD;
}

absl::StatusOr<ConeDirection> FromWire(v1::ConeDirection d) {
  switch (d) {
    case v1::CONE_DIRECTION_UNSPECIFIED:
    case v1::CONE_DIRECTION_INWARD:
      return ConeDirection::kInward;
    case v1::CONE_DIRECTION_OUTWARD:
      return ConeDirection::kOutward;
    default:
      return absl::InvalidArgumentError(absl::StrCat(
          "cone direction ", static_cast<int>(d), " is not a known one"));
  }
}

void ToWire(const MissingValues& m, v1::MissingValues* out) {
  out->set_vertices(m.vertices);
  out->set_faces(m.faces);
  out->set_area_fraction(m.area_fraction);
}

MissingValues FromWire(const v1::MissingValues& m) {
  MissingValues out;
  out.vertices = m.vertices();
  out.faces = m.faces();
  out.area_fraction = m.area_fraction();
  return out;
}

void ToWire(const SessionInfo& s, v1::SessionInfo* out) {
  out->set_session_id(s.session_id);
  out->set_dimension(s.dimension);
  out->set_num_vertices(s.num_vertices);
  out->set_num_faces(s.num_faces);
  out->set_generation(s.generation);
  out->set_memory_bytes(s.memory_bytes);
  out->set_bvh_builds(s.bvh_builds);
  out->set_bvh_refits(s.bvh_refits);
  out->set_idle_seconds(s.idle_seconds);
  out->set_signed_volume(s.signed_volume);
  out->set_closed(s.closed);
  for (const std::string& w : s.warnings) out->add_warnings(w);
}

SessionInfo FromWire(const v1::SessionInfo& s) {
  SessionInfo out;
  out.session_id = s.session_id();
  out.dimension = s.dimension();
  out.num_vertices = s.num_vertices();
  out.num_faces = s.num_faces();
  out.generation = s.generation();
  out.memory_bytes = s.memory_bytes();
  out.bvh_builds = s.bvh_builds();
  out.bvh_refits = s.bvh_refits();
  out.idle_seconds = s.idle_seconds();
  out.signed_volume = s.signed_volume();
  out.closed = s.closed();
  out.warnings.assign(s.warnings().begin(), s.warnings().end());
  return out;
}

void ToWire(const CalibrationReport& r, v1::CalibrateResponse* out) {
  out->set_compared(r.compared);
  out->set_sdf_lower(r.lower);
  out->set_sdf_equal(r.equal);
  out->set_sdf_higher(r.higher);
  out->set_alpha1(r.alpha1);
  out->set_alpha2(r.alpha2);
  out->set_histogram_lo(r.sdf_histogram.lo);
  out->set_histogram_hi(r.sdf_histogram.hi);
  out->mutable_sdf_histogram()->Add(r.sdf_histogram.counts.begin(),
                                    r.sdf_histogram.counts.end());
  out->mutable_thickness_histogram()->Add(r.thickness_histogram.counts.begin(),
                                          r.thickness_histogram.counts.end());
  out->set_ball_compared(r.ball_compared);
  out->set_ball_lower(r.ball_lower);
  out->set_ball_equal(r.ball_equal);
  out->set_ball_higher(r.ball_higher);
  out->set_ball_alpha(r.ball_alpha);
  out->mutable_ball_histogram()->Add(r.ball_histogram.counts.begin(),
                                     r.ball_histogram.counts.end());
}

CalibrationReport FromWire(const v1::CalibrateResponse& r) {
  CalibrationReport out;
  out.compared = r.compared();
  out.lower = r.sdf_lower();
  out.equal = r.sdf_equal();
  out.higher = r.sdf_higher();
  out.alpha1 = r.alpha1();
  out.alpha2 = r.alpha2();
  out.ball_compared = r.ball_compared();
  out.ball_lower = r.ball_lower();
  out.ball_equal = r.ball_equal();
  out.ball_higher = r.ball_higher();
  out.ball_alpha = r.ball_alpha();
  for (Histogram* h :
       {&out.sdf_histogram, &out.thickness_histogram, &out.ball_histogram}) {
    h->lo = r.histogram_lo();
    h->hi = r.histogram_hi();
  }
  out.sdf_histogram.counts.assign(r.sdf_histogram().begin(),
                                  r.sdf_histogram().end());
  out.thickness_histogram.counts.assign(r.thickness_histogram().begin(),
                                        r.thickness_histogram().end());
  out.ball_histogram.counts.assign(r.ball_histogram().begin(),
                                   r.ball_histogram().end());
  return out;
}

namespace {

void PointToWire(const Vec3& p, google::protobuf::RepeatedField<double>* out) {
  out->Add(p.x);
  out->Add(p.y);
  out->Add(p.z);
}

absl::StatusOr<Vec3> PointFromWire(
    const google::protobuf::RepeatedField<double>& p, const char* field) {
  if (p.size() != 3) {
    return absl::DataLossError(absl::StrCat("thin region ", field, " has ",
                                            p.size(), " values, not 3"));
  }
  return Vec3{p[0], p[1], p[2]};
}

}  // namespace

void ToWire(const ThinSurface& t, int max_regions, v1::ThinSurface* out) {
  out->set_total_area(t.total_area);
  out->set_missing_area(t.missing_area);
  out->set_thin_area(t.thin_area);
  out->set_min_thickness(t.min_thickness);
  out->set_min_vertex(t.min_vertex);
  if (t.min_face >= 0) out->set_min_face(t.min_face);
  PointToWire(t.min_point, out->mutable_min_point());
  out->set_region_count(std::ssize(t.regions));
  const int n = std::min<int64_t>(max_regions, std::ssize(t.regions));
  for (int i = 0; i < n; ++i) {
    const ThinRegion& r = t.regions[i];
    v1::ThinRegion* w = out->add_regions();
    w->set_faces(r.faces);
    w->set_area(r.area);
    w->set_min_thickness(r.min_thickness);
    w->set_min_vertex(r.min_vertex);
    if (r.min_face >= 0) w->set_min_face(r.min_face);
    PointToWire(r.min_point, w->mutable_min_point());
    PointToWire(r.centroid, w->mutable_centroid());
    PointToWire(r.box_min, w->mutable_box_min());
    PointToWire(r.box_max, w->mutable_box_max());
    w->set_speck(r.speck);
  }
}

absl::StatusOr<ThinSurface> FromWire(const v1::ThinSurface& t, double t_min) {
  ThinSurface out;
  out.t_min = t_min;
  out.total_area = t.total_area();
  out.missing_area = t.missing_area();
  out.thin_area = t.thin_area();
  out.min_thickness = t.min_thickness();
  out.min_vertex = t.min_vertex();
  out.min_face = t.has_min_face() ? t.min_face() : -1;
  auto min_point = PointFromWire(t.min_point(), "min_point");
  if (!min_point.ok()) return min_point.status();
  out.min_point = *min_point;
  for (const v1::ThinRegion& w : t.regions()) {
    ThinRegion r;
    r.faces = w.faces();
    r.area = w.area();
    r.min_thickness = w.min_thickness();
    r.min_vertex = w.min_vertex();
    r.min_face = w.has_min_face() ? w.min_face() : -1;
    r.speck = w.speck();
    for (auto [field, point, name] :
         {std::tuple{&w.min_point(), &r.min_point, "min_point"},
          std::tuple{&w.centroid(), &r.centroid, "centroid"},
          std::tuple{&w.box_min(), &r.box_min, "box_min"},
          std::tuple{&w.box_max(), &r.box_max, "box_max"}}) {
      auto p = PointFromWire(*field, name);
      if (!p.ok()) return p.status();
      *point = *p;
    }
    out.regions.push_back(r);
  }
  return out;
}

void AppendFlattened(absl::Span<const Vec3> v, int dimension,
                     google::protobuf::RepeatedField<double>* out) {
  out->Reserve(out->size() + static_cast<int>(v.size()) * dimension);
  for (const Vec3& p : v) {
    for (int c = 0; c < dimension; ++c) out->AddAlreadyReserved(p[c]);
  }
}

void AppendFaces(absl::Span<const Face> faces,
                 google::protobuf::RepeatedField<int32_t>* sizes,
                 google::protobuf::RepeatedField<int32_t>* indices) {
  sizes->Reserve(sizes->size() + static_cast<int>(faces.size()));
  for (const Face& f : faces) {
    sizes->AddAlreadyReserved(f.size);
    indices->Add(f.v.begin(), f.v.begin() + f.size);
  }
}

void ToWire(const Mesh& mesh, int64_t generation, v1::GetMeshResponse* out) {
  out->set_dimension(mesh.dimension);
  out->set_generation(generation);
  AppendFlattened(mesh.positions, mesh.dimension, out->mutable_positions());
  AppendFaces(mesh.faces, out->mutable_face_sizes(),
              out->mutable_face_indices());
  out->mutable_face_regions()->Add(mesh.face_regions.begin(),
                                   mesh.face_regions.end());
}

absl::StatusOr<std::vector<Vec3>> ToPoints(
    const google::protobuf::RepeatedField<double>& flat, int dimension,
    const char* field) {
  if (flat.size() % dimension != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, " has ", flat.size(),
                     " values, not a multiple of the dimension ", dimension));
  }
  std::vector<Vec3> out(flat.size() / dimension);
  for (int i = 0; i < flat.size(); ++i) {
    if (!std::isfinite(flat[i])) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, "[", i, "] is not finite"));
    }
    out[i / dimension][i % dimension] = flat[i];
  }
  return out;
}

absl::StatusOr<SampleRange> FromWire(const v1::SampleRange& r) {
  if (r.begin() < 0 || r.begin() >= r.end()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "range [", r.begin(), ", ", r.end(),
        ") is empty or negative: a range needs 0 <= begin < end"));
  }
  return SampleRange{r.begin(), r.end()};
}

void ToWire(const SampleRange& r, v1::SampleRange* out) {
  out->set_begin(r.begin);
  out->set_end(r.end);
}

void ToWireChunk(const SdfResult& r, const SparseJacobian* jacobian,
                 int dimension, int64_t begin, int64_t end, v1::SdfChunk* c) {
  const int64_t first = r.resolved.params.range.begin;
  c->set_vertex_begin(first + begin);
  c->set_vertex_end(first + end);
  c->mutable_values()->Add(r.values.begin() + begin, r.values.begin() + end);
  for (int64_t p = begin; p < end; ++p) c->add_status(ToWire(r.status[p]));
  c->mutable_hits()->Add(r.hits.begin() + begin, r.hits.begin() + end);
  c->mutable_kept()->Add(r.kept.begin() + begin, r.kept.begin() + end);
  c->mutable_normalized()->Add(r.normalized.begin() + begin,
                               r.normalized.begin() + end);
  if (!r.opposite.empty()) {
    for (int64_t p = begin; p < end; ++p) {
      for (int k = 0; k < 3; ++k) c->add_opposite(r.opposite[p][k]);
    }
  }
  if (!jacobian) return;
  const SparseJacobian& j = *jacobian;
  const int64_t base = j.row_offsets[begin];
  for (int64_t p = begin; p <= end; ++p) {
    c->add_row_offsets(j.row_offsets[p] - base);
  }
  for (int64_t e = base; e < j.row_offsets[end]; ++e) {
    c->add_columns(j.columns[e]);
    for (int k = 0; k < dimension; ++k) c->add_derivatives(j.values[e][k]);
  }
}

void ToWireSummary(const SdfResult& r, double integral, const CallFacts& facts,
                   v1::SdfSummary* s) {
  s->set_generation(facts.generation);
  s->set_samples(r.resolved.params.samples == SampleSet::kFaces
                     ? v1::SAMPLE_SET_FACES
                     : v1::SAMPLE_SET_VERTICES);
  s->set_ok(r.CountStatus(VertexStatus::kOk));
  s->set_no_hit(r.CountStatus(VertexStatus::kNoHit));
  s->set_no_faces(r.CountStatus(VertexStatus::kNoFaces));
  s->set_degenerate_normal(r.CountStatus(VertexStatus::kDegenerateNormal));
  const ValueStats stats = SummarizeValues(r.values);
  s->set_sdf_min(stats.min);
  s->set_sdf_max(stats.max);
  s->set_sdf_mean(stats.mean);
  s->set_sdf_median(stats.median);
  s->set_world_frame_vertices(r.world_frame_vertices);
  ToWire(r.missing, s->mutable_missing());
  s->set_integral(integral);
  s->set_rays(r.rays_traced);
  s->set_rays_per_vertex(r.resolved.rays);
  s->set_trace_seconds(facts.reused_hits ? 0.0 : r.trace_seconds);
  s->set_reused_hits(facts.reused_hits);
  s->set_seconds(facts.seconds);
  if (!r.resolved.params.range.all()) {
    ToWire(r.resolved.params.range, s->mutable_range());
  }
}

absl::Status AppendChunk(const v1::SdfChunk& c, SdfReply* reply,
                         int64_t first_sample) {
  SdfResult& r = reply->result;
  const int64_t n = c.vertex_end() - c.vertex_begin();
  if (c.vertex_begin() != first_sample + std::ssize(r.values) || n < 0 ||
      c.values_size() != n || c.status_size() != n || c.hits_size() != n ||
      c.kept_size() != n || c.normalized_size() != n ||
      (c.opposite_size() != 0 && c.opposite_size() != 3 * n) ||
      (!r.values.empty() && (c.opposite_size() > 0) != !r.opposite.empty())) {
    return Malformed(absl::StrCat("chunk [", c.vertex_begin(), ", ",
                                  c.vertex_end(), ") does not continue ",
                                  r.values.size(), " samples"));
  }
  r.values.insert(r.values.end(), c.values().begin(), c.values().end());
  for (int s : c.status()) {
    auto status = FromWire(static_cast<v1::VertexStatus>(s));
    if (!status.ok()) return status.status();
    r.status.push_back(*status);
  }
  r.hits.insert(r.hits.end(), c.hits().begin(), c.hits().end());
  r.kept.insert(r.kept.end(), c.kept().begin(), c.kept().end());
  r.normalized.insert(r.normalized.end(), c.normalized().begin(),
                      c.normalized().end());
  for (int i = 0; i + 2 < c.opposite_size(); i += 3) {
    r.opposite.push_back(
        Vec3(c.opposite(i), c.opposite(i + 1), c.opposite(i + 2)));
  }
  if (!reply->jacobian) return absl::OkStatus();
  SparseJacobian& j = *reply->jacobian;
  if (j.row_offsets.empty()) j.row_offsets.push_back(0);
  if (c.row_offsets_size() != n + 1 || c.row_offsets(n) != c.columns_size() ||
      (c.columns_size() > 0 && c.derivatives_size() != 2 * c.columns_size() &&
       c.derivatives_size() != 3 * c.columns_size())) {
    return Malformed("Jacobian rows do not match the chunk");
  }
  const int64_t base = j.nonzeros();
  for (int i = 1; i <= n; ++i) j.row_offsets.push_back(base + c.row_offsets(i));
  const int dim =
      c.columns_size() ? c.derivatives_size() / c.columns_size() : 3;
  for (int e = 0; e < c.columns_size(); ++e) {
    j.columns.push_back(c.columns(e));
    Vec3 d;
    for (int k = 0; k < dim; ++k) d[k] = c.derivatives(e * dim + k);
    j.values.push_back(d);
  }
  return absl::OkStatus();
}

absl::Status FinishReply(const v1::SdfSummary& s, const SdfParams& params,
                         SdfReply* reply) {
  SdfResult& r = reply->result;
  if (s.ok() + s.no_hit() + s.no_faces() + s.degenerate_normal() !=
          std::ssize(r.values) ||
      s.ok() != r.CountStatus(VertexStatus::kOk)) {
    return Malformed(absl::StrCat("the summary counts ", s.ok(),
                                  " values, the chunks carried ",
                                  r.CountStatus(VertexStatus::kOk)));
  }
  if (std::ssize(r.opposite) !=
      (params.opposite_points ? std::ssize(r.values) : 0)) {
    return Malformed(absl::StrCat(
        params.opposite_points ? "opposite points were asked for, "
                               : "no opposite points were asked for, ",
        "the chunks carried ", r.opposite.size(), " for ", r.values.size(),
        " samples (is the server older than SdfParameters.opposite_points?)"));
  }
  const SampleRange range = s.has_range()
                                ? SampleRange{s.range().begin(), s.range().end()}
                                : SampleRange{};
  if (range != params.range) {
    return Malformed(absl::StrCat(
        "samples [", params.range.begin, ", ", params.range.end,
        ") were asked for, the reply holds [", range.begin, ", ", range.end,
        ") (is the server older than ComputeSdfRequest.range?)"));
  }
  const bool faces = params.samples == SampleSet::kFaces;
  if (faces ? s.samples() != v1::SAMPLE_SET_FACES
            : s.samples() == v1::SAMPLE_SET_FACES) {
    return Malformed(absl::StrCat(
        SampleName(params.samples), " samples were asked for, the reply holds ",
        faces ? "others" : "face samples",
        " (is the server older than SdfParameters.samples?)"));
  }
  r.rays_traced = s.rays();
  r.world_frame_vertices = s.world_frame_vertices();
  r.missing = FromWire(s.missing());
  r.trace_seconds = s.trace_seconds();
  r.resolved.params = params;
  r.resolved.rays = s.rays_per_vertex();
  reply->integral = s.integral();
  reply->facts = {s.generation(), s.reused_hits(), s.seconds()};
  return absl::OkStatus();
}

grpc::Status ToGrpc(const absl::Status& s) {
  if (s.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(s.code()),
                      std::string(s.message()));
}

absl::Status FromGrpc(const grpc::Status& s) {
  if (s.ok()) return absl::OkStatus();
  return absl::Status(static_cast<absl::StatusCode>(s.error_code()),
                      s.error_message());
}

}  // namespace meshgauge::wire

#include "server/proto_convert.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace meshgauge::server {

absl::StatusOr<SdfParams> ToSdfParams(const v1::SdfParameters& p, int max_rays,
                                      int threads) {
  SdfParams out;
  switch (p.method()) {
    case v1::SDF_METHOD_UNSPECIFIED:
    case v1::SDF_METHOD_CONE:
      out.method = SdfMethod::kCone;
      break;
    case v1::SDF_METHOD_NORMAL_RAY:
      out.method = SdfMethod::kNormalRay;
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
  if (p.cone_angle_degrees() != 0)
    out.cone_angle_degrees = p.cone_angle_degrees();
  out.rays = p.rays();
  if (p.has_kappa()) out.kappa = p.kappa();
  out.min_weight_angle = p.min_weight_angle();
  out.max_distance = p.max_distance();
  if (p.self_hit_epsilon() != 0) out.self_hit_epsilon = p.self_hit_epsilon();
  out.threads = threads;
  if (p.rays() > max_rays) {
    return absl::InvalidArgumentError(absl::StrCat(
        "params.rays ", p.rays(), " exceeds the server's limit of ", max_rays,
        " rays per vertex (--max_rays)"));
  }
  if (absl::Status s = ValidateParams(out); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("params: ", s.message()));
  }
  return out;
}

absl::StatusOr<PenaltyParams> ToPenaltyParams(
    const v1::ComputePenaltyRequest& r) {
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

v1::VertexStatus ToProto(VertexStatus s) {
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

void ToProto(const MissingValues& m, v1::MissingValues* out) {
  out->set_vertices(m.vertices);
  out->set_faces(m.faces);
  out->set_area_fraction(m.area_fraction);
}

void ToProto(const SessionSnapshot& s, double now, v1::SessionInfo* out) {
  const RecordInfo& i = s.info;
  out->set_session_id(i.id);
  out->set_dimension(i.dimension);
  out->set_num_vertices(i.num_vertices);
  out->set_num_faces(i.num_faces);
  out->set_generation(i.generation);
  out->set_memory_bytes(i.memory_bytes);
  out->set_bvh_builds(s.bvh_builds);
  out->set_bvh_refits(s.bvh_refits);
  out->set_idle_seconds(std::max(0.0, now - s.last_used));
  out->set_signed_volume(i.signed_volume);
  out->set_closed(i.closed);
  for (const std::string& w : i.warnings) out->add_warnings(w);
}

void AppendFlattened(const std::vector<Vec3>& v, int dimension,
                     google::protobuf::RepeatedField<double>* out) {
  out->Reserve(out->size() + static_cast<int>(v.size()) * dimension);
  for (const Vec3& p : v) {
    for (int c = 0; c < dimension; ++c) out->AddAlreadyReserved(p[c]);
  }
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

grpc::Status ToGrpc(const absl::Status& s) {
  if (s.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(s.code()),
                      std::string(s.message()));
}

}  // namespace meshgauge::server

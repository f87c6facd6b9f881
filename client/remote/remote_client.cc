#include "client/remote/remote_client.h"

#include <grpcpp/generic/generic_stub.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <future>
#include <random>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "lib/io/text_file.h"

namespace meshgauge::client {
namespace {

template <typename T>
uLong CrcOf(uLong crc, const std::vector<T>& v) {
  return v.empty() ? crc
                   : crc32(crc, reinterpret_cast<const Bytef*>(v.data()),
                           v.size() * sizeof(T));
}

}  // namespace

absl::Status FromGrpc(const grpc::Status& s) {
  if (s.ok()) return absl::OkStatus();
  return absl::Status(static_cast<absl::StatusCode>(s.error_code()),
                      s.error_message());
}

uint32_t MeshCrc32(const Mesh& mesh) {
  std::vector<double> coords;
  coords.reserve(mesh.positions.size() * mesh.dimension);
  for (const Vec3& p : mesh.positions) {
    for (int c = 0; c < mesh.dimension; ++c) coords.push_back(p[c]);
  }
  std::vector<int32_t> sizes, indices;
  for (const Face& f : mesh.faces) {
    sizes.push_back(f.size);
    for (int k = 0; k < f.size; ++k) indices.push_back(f.v[k]);
  }
  uLong crc = crc32(0, nullptr, 0);
  crc = CrcOf(crc, coords);
  crc = CrcOf(crc, sizes);
  crc = CrcOf(crc, indices);
  crc = CrcOf(crc, mesh.face_regions);
  return static_cast<uint32_t>(crc);
}

v1::SdfParameters ToWireParams(const SdfParams& p) {
  v1::SdfParameters w;
  w.set_method(p.method == SdfMethod::kNormalRay ? v1::SDF_METHOD_NORMAL_RAY
                                                 : v1::SDF_METHOD_CONE);
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

std::vector<Vec3> FromFlattened(
    const google::protobuf::RepeatedField<double>& flat, int dimension) {
  std::vector<Vec3> out(flat.size() / dimension);
  for (int i = 0; i < flat.size(); ++i)
    out[i / dimension][i % dimension] = flat[i];
  return out;
}

absl::Status LoadClientSecrets(const std::string& ca_file,
                               const std::string& cert_file,
                               const std::string& key_file,
                               const std::string& token_file,
                               ClientOptions* options) {
  const std::pair<const std::string*, std::string*> pems[] = {
      {&ca_file, &options->tls_ca_pem},
      {&cert_file, &options->tls_cert_pem},
      {&key_file, &options->tls_key_pem}};
  for (const auto& [path, out] : pems) {
    if (path->empty()) continue;
    auto text = ReadTextFile(*path, "TLS file");
    if (!text.ok()) return text.status();
    *out = std::move(*text);
  }
  if (!token_file.empty()) {
    auto text = ReadTextFile(token_file, "token file");
    if (!text.ok()) return text.status();
    options->token = std::string(absl::StripAsciiWhitespace(
        absl::string_view(*text).substr(0, text->find('\n'))));
  } else if (const char* env = std::getenv("MESHGAUGE_TOKEN")) {
    options->token = std::string(absl::StripAsciiWhitespace(env));
  }
  return absl::OkStatus();
}

std::string NewSessionId() {
  thread_local std::mt19937_64 rng(std::random_device{}());
  const uint64_t hi = rng(), lo = rng();
  // RFC 4122 version 4 (random), variant 10.
  return absl::StrFormat("%08x-%04x-4%03x-%04x-%012x", hi >> 32,
                         (hi >> 16) & 0xffff, hi & 0xfff,
                         0x8000 | ((lo >> 48) & 0x3fff),
                         lo & 0xffffffffffffull);
}

const char kRetryServiceConfig[] = R"json({
  "methodConfig": [{
    "name": [{"service": "meshgauge.v1.MeshGauge"}],
    "retryPolicy": {
      "maxAttempts": 5,
      "initialBackoff": "0.2s",
      "maxBackoff": "3s",
      "backoffMultiplier": 2.5,
      "retryableStatusCodes": ["UNAVAILABLE"]
    }
  }]
})json";

RemoteClient::RemoteClient(const std::string& target, ClientOptions options)
    : options_(options) {
  grpc::ChannelArguments args;
  if (options.retry) {
    args.SetServiceConfigJSON(kRetryServiceConfig);
    args.SetInt(GRPC_ARG_ENABLE_RETRIES, 1);
  }
  const int max_bytes =
      static_cast<int>(std::min<int64_t>(options.max_message_bytes, INT32_MAX));
  args.SetMaxReceiveMessageSize(max_bytes);
  args.SetMaxSendMessageSize(max_bytes);
  std::shared_ptr<grpc::ChannelCredentials> creds =
      grpc::InsecureChannelCredentials();
  if (!options.tls_ca_pem.empty()) {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = options.tls_ca_pem;
    ssl.pem_cert_chain = options.tls_cert_pem;
    ssl.pem_private_key = options.tls_key_pem;
    creds = grpc::SslCredentials(ssl);
  }
  channel_ = grpc::CreateCustomChannel(target, creds, args);
  stub_ = v1::MeshGauge::NewStub(channel_);
}

std::unique_ptr<grpc::ClientContext> RemoteClient::Context(
    const std::string& session_id) const {
  auto ctx = std::make_unique<grpc::ClientContext>();
  if (channel_->GetState(/*try_to_connect=*/true) != GRPC_CHANNEL_READY &&
      !channel_->WaitForConnected(
          std::chrono::system_clock::now() +
          std::chrono::duration_cast<std::chrono::system_clock::duration>(
              std::chrono::duration<double>(
                  std::min(options_.connect_timeout_seconds,
                           options_.deadline_seconds))))) {
    ctx->set_wait_for_ready(false);  // fail now, do not wait for ready.
  }
  ctx->set_deadline(
      std::chrono::system_clock::now() +
      std::chrono::duration_cast<std::chrono::system_clock::duration>(
          std::chrono::duration<double>(options_.deadline_seconds)));
  // Metadata values must be printable ASCII (gRPC aborts the process on
  // others); an id that is not gets no routing key, and the server rejects
  // it with a precise message.
  const bool printable =
      std::all_of(session_id.begin(), session_id.end(),
                  [](char c) { return c >= 0x20 && c <= 0x7e; });
  if (!session_id.empty() && printable) {
    ctx->AddMetadata(kSessionMetadataKey, session_id);
  }
  if (!options_.token.empty()) {
    ctx->AddMetadata(kAuthorizationMetadataKey, "Bearer " + options_.token);
  }
  return ctx;
}

absl::StatusOr<v1::SessionInfo> RemoteClient::Upload(
    const Mesh& mesh, const std::string& requested_id) {
  const std::string session_id =
      requested_id.empty() ? NewSessionId() : requested_id;
  auto ctx = Context(session_id);
  v1::CreateSessionResponse response;
  auto writer = stub_->CreateSession(ctx.get(), &response);
  v1::CreateSessionRequest req;
  auto* h = req.mutable_header();
  h->set_session_id(session_id);
  h->set_dimension(mesh.dimension);
  h->set_num_vertices(mesh.num_vertices());
  h->set_num_faces(mesh.num_faces());
  for (const auto& [region, dir] : mesh.region_directions) {
    auto* rd = h->add_region_directions();
    rd->set_region(region);
    rd->set_direction(dir == ConeDirection::kOutward
                          ? v1::CONE_DIRECTION_OUTWARD
                          : v1::CONE_DIRECTION_INWARD);
  }
  bool ok = writer->Write(req);
  const int64_t step = std::max(1, options_.upload_chunk_vertices);
  const int64_t n = std::max(mesh.num_vertices(), mesh.num_faces());
  for (int64_t begin = 0; ok && begin < n; begin += step) {
    req.Clear();
    auto* c = req.mutable_chunk();
    for (int64_t i = begin; i < std::min(begin + step, mesh.num_vertices());
         ++i) {
      for (int d = 0; d < mesh.dimension; ++d)
        c->add_positions(mesh.positions[i][d]);
    }
    for (int64_t f = begin; f < std::min(begin + step, mesh.num_faces()); ++f) {
      const Face& face = mesh.faces[f];
      c->add_face_sizes(face.size);
      for (int k = 0; k < face.size; ++k) c->add_face_indices(face.v[k]);
      if (!mesh.face_regions.empty()) c->add_face_regions(mesh.face_regions[f]);
    }
    ok = writer->Write(req);
  }
  if (ok) {
    req.Clear();
    auto* footer = req.mutable_footer();
    footer->set_num_vertices(mesh.num_vertices());
    footer->set_num_faces(mesh.num_faces());
    footer->set_crc32(MeshCrc32(mesh));
    writer->Write(req);
  }
  writer->WritesDone();
  if (absl::Status s = FromGrpc(writer->Finish()); !s.ok()) return s;
  return response.session();
}

absl::StatusOr<bool> RemoteClient::Serving() {
  // The health protocol by hand-encoded bytes (no generated health stubs):
  // the request is empty; the response is field 1 (status) as a varint,
  // 1 = SERVING, 2 = NOT_SERVING.
  grpc::GenericStub stub(channel_);
  auto ctx = Context("");
  grpc::Slice empty("");
  grpc::ByteBuffer request(&empty, 1), response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(ctx.get(), "/grpc.health.v1.Health/Check", grpc::StubOptions(),
                 &request, &response,
                 [&done](grpc::Status s) { done.set_value(std::move(s)); });
  if (absl::Status s = FromGrpc(done.get_future().get()); !s.ok()) return s;
  std::vector<grpc::Slice> slices;
  if (!response.Dump(&slices).ok()) {
    return absl::DataLossError("unreadable health response");
  }
  std::string bytes;
  for (const auto& s : slices) bytes.append(s.begin(), s.end());
  if (bytes.size() != 2 || bytes[0] != 0x08) {
    return absl::DataLossError("unexpected health response");
  }
  return bytes[1] == 1;
}

absl::StatusOr<v1::SessionInfo> RemoteClient::Get(const std::string& id) {
  auto ctx = Context(id);
  v1::GetSessionRequest req;
  req.set_session_id(id);
  v1::GetSessionResponse resp;
  if (absl::Status s = FromGrpc(stub_->GetSession(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return resp.session();
}

absl::StatusOr<std::vector<v1::SessionInfo>> RemoteClient::List(int page_size) {
  std::vector<v1::SessionInfo> all;
  v1::ListSessionsRequest req;
  req.set_page_size(page_size);
  do {
    auto ctx = Context("");
    v1::ListSessionsResponse resp;
    if (absl::Status s = FromGrpc(stub_->ListSessions(ctx.get(), req, &resp));
        !s.ok()) {
      return s;
    }
    all.insert(all.end(), resp.sessions().begin(), resp.sessions().end());
    req.set_page_token(resp.next_page_token());
  } while (!req.page_token().empty());
  return all;
}

absl::Status RemoteClient::Delete(const std::string& id) {
  auto ctx = Context(id);
  v1::DeleteSessionRequest req;
  req.set_session_id(id);
  v1::DeleteSessionResponse resp;
  return FromGrpc(stub_->DeleteSession(ctx.get(), req, &resp));
}

absl::StatusOr<v1::UpdatePositionsResponse> RemoteClient::UpdatePositions(
    const std::string& id, int64_t expected_generation, int dimension,
    const std::vector<Vec3>& positions, const std::vector<int32_t>& indices) {
  auto ctx = Context(id);
  v1::UpdatePositionsRequest req;
  req.set_session_id(id);
  req.set_expected_generation(expected_generation);
  req.mutable_indices()->Add(indices.begin(), indices.end());
  req.mutable_positions()->Reserve(static_cast<int>(positions.size()) *
                                   dimension);
  for (const Vec3& p : positions) {
    for (int d = 0; d < dimension; ++d) req.add_positions(p[d]);
  }
  v1::UpdatePositionsResponse resp;
  if (absl::Status s = FromGrpc(stub_->UpdatePositions(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return resp;
}

absl::StatusOr<RemoteSdf> RemoteClient::ComputeSdf(
    const std::string& id, const v1::SdfParameters& params,
    bool include_jacobian, std::optional<int64_t> expected_generation,
    int chunk_vertices) {
  auto ctx = Context(id);
  v1::ComputeSdfRequest req;
  req.set_session_id(id);
  *req.mutable_params() = params;
  req.set_include_jacobian(include_jacobian);
  req.set_chunk_vertices(chunk_vertices);
  if (expected_generation) req.set_expected_generation(*expected_generation);
  auto reader = stub_->ComputeSdf(ctx.get(), req);
  RemoteSdf out;
  if (include_jacobian) {
    out.jacobian.emplace();
    out.jacobian->row_offsets.push_back(0);
  }
  v1::ComputeSdfResponse msg;
  while (reader->Read(&msg)) {
    if (msg.has_summary()) {
      out.summary = msg.summary();
      continue;
    }
    const v1::SdfChunk& c = msg.chunk();
    out.values.insert(out.values.end(), c.values().begin(), c.values().end());
    for (int s : c.status())
      out.status.push_back(static_cast<v1::VertexStatus>(s));
    out.hits.insert(out.hits.end(), c.hits().begin(), c.hits().end());
    out.kept.insert(out.kept.end(), c.kept().begin(), c.kept().end());
    out.normalized.insert(out.normalized.end(), c.normalized().begin(),
                          c.normalized().end());
    if (out.jacobian && c.row_offsets_size() > 0) {
      SparseJacobian& j = *out.jacobian;
      const int64_t base = j.nonzeros();
      for (int r = 1; r < c.row_offsets_size(); ++r) {
        j.row_offsets.push_back(base + c.row_offsets(r));
      }
      const int dim =
          c.columns_size() ? c.derivatives_size() / c.columns_size() : 3;
      for (int e = 0; e < c.columns_size(); ++e) {
        j.columns.push_back(c.columns(e));
        Vec3 d;
        for (int k = 0; k < dim; ++k) d[k] = c.derivatives(e * dim + k);
        j.values.push_back(d);
      }
    }
  }
  if (absl::Status s = FromGrpc(reader->Finish()); !s.ok()) return s;
  return out;
}

absl::StatusOr<v1::ComputeVjpResponse> RemoteClient::ComputeVjp(
    const std::string& id, const v1::SdfParameters& params,
    const std::vector<double>& weights,
    std::optional<int64_t> expected_generation) {
  auto ctx = Context(id);
  v1::ComputeVjpRequest req;
  req.set_session_id(id);
  *req.mutable_params() = params;
  if (expected_generation) req.set_expected_generation(*expected_generation);
  req.mutable_weights()->Add(weights.begin(), weights.end());
  v1::ComputeVjpResponse resp;
  if (absl::Status s = FromGrpc(stub_->ComputeVjp(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return resp;
}

absl::StatusOr<v1::ComputePenaltyResponse> RemoteClient::ComputePenalty(
    const std::string& id, const v1::SdfParameters& params,
    const PenaltyParams& penalty, bool with_gradient,
    std::optional<int64_t> expected_generation) {
  auto ctx = Context(id);
  v1::ComputePenaltyRequest req;
  req.set_session_id(id);
  *req.mutable_params() = params;
  req.set_t_min(penalty.t_min);
  switch (penalty.form) {
    case PenaltyForm::kOneSided:
      req.set_form(v1::PENALTY_FORM_ONE_SIDED);
      break;
    case PenaltyForm::kThesis:
      req.set_form(v1::PENALTY_FORM_THESIS);
      break;
    case PenaltyForm::kKs:
      req.set_form(v1::PENALTY_FORM_KS);
      break;
  }
  req.set_power(penalty.power);
  req.set_rho(penalty.rho);
  req.set_max_missing_fraction(penalty.max_missing_fraction);
  req.set_with_gradient(with_gradient);
  if (expected_generation) req.set_expected_generation(*expected_generation);
  v1::ComputePenaltyResponse resp;
  if (absl::Status s = FromGrpc(stub_->ComputePenalty(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return resp;
}

absl::StatusOr<v1::CalibrateResponse> RemoteClient::Calibrate(
    const std::string& id, const v1::SdfParameters& params, double t_min,
    double equal_tolerance, int bins) {
  auto ctx = Context(id);
  v1::CalibrateRequest req;
  req.set_session_id(id);
  *req.mutable_params() = params;
  req.set_t_min(t_min);
  req.set_equal_tolerance(equal_tolerance);
  req.set_bins(bins);
  v1::CalibrateResponse resp;
  if (absl::Status s = FromGrpc(stub_->Calibrate(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return resp;
}

}  // namespace meshgauge::client

#include "absl/strings/str_cat.h"
#include "client/cli/backend.h"
#include "client/cli/progress_bar.h"
#include "client/remote/remote_client.h"
#include "lib/core/face_sample.h"

namespace meshgauge::cli {
namespace {

class Remote : public Backend {
 public:
  Remote(std::shared_ptr<client::RemoteClient> c, std::string id,
         bool temporary, Mesh mesh, ProgressMode progress, int fan_out)
      : c_(std::move(c)),
        id_(std::move(id)),
        temporary_(temporary),
        mesh_(std::move(mesh)),
        progress_(progress),
        fan_out_(fan_out) {}
  ~Remote() override {
    if (temporary_) (void)c_->Delete(id_);
  }

  const Mesh& mesh() const override { return mesh_; }

  absl::StatusOr<SdfResult> Sdf(const SdfParams& params,
                                Derivatives derivatives) override {
    params_ = params;
    const int64_t rays = ResolveParams(params, mesh_.dimension).rays;
    ProgressBar bar(
        absl::StrCat("tracing ", NumSamples(mesh_, params.samples) * rays,
                     " rays on the server"),
        progress_);
    client::SdfCall call{
        .include_jacobian = derivatives == Derivatives::kJacobian,
        .fan_out = fan_out_,
        .mesh = &mesh_};
    if (bar.enabled()) {
      call.progress = [&bar](int64_t done, int64_t total) {
        bar.Update(done, total);
      };
    }
    auto r = c_->ComputeSdf(id_, params, call);
    bar.Finish();
    if (!r.ok()) return r.status();
    // The outputs index the mesh file's vertices or faces by these values.
    if (const int64_t n = NumSamples(mesh_, params.samples);
        std::ssize(r->result.values) != n) {
      return absl::DataLossError(
          absl::StrCat("the server sent ", r->result.values.size(),
                       " values for ", n, " ", SampleSetName(params.samples)));
    }
    jacobian_ = std::move(r->jacobian);
    generation_ = r->facts.generation;
    return std::move(r->result);
  }
  absl::StatusOr<SparseJacobian> Jacobian() override {
    if (!jacobian_) return absl::InternalError("Sdf(params, kJacobian) first");
    return *jacobian_;
  }
  absl::StatusOr<std::vector<Vec3>> Vjp(
      const std::vector<double>& weights) override {
    auto r = c_->ComputeVjp(id_, params_, weights, generation_, fan_out_);
    if (!r.ok()) return r.status();
    return std::move(r->gradient);
  }
  // The server holds the pass; a fanned-out penalty sends the pass's values
  // with each range.
  absl::StatusOr<PenaltyResult> Penalty(const SdfResult& pass,
                                        const PenaltyParams& params,
                                        bool with_gradient) override {
    auto r = c_->ComputePenalty(id_, params_, params, with_gradient,
                                generation_, fan_out_, pass.values);
    if (!r.ok()) return r.status();
    return std::move(r->penalty);
  }
  absl::StatusOr<CalibrationReport> Calibrate(
      const CalibrationParams& params) override {
    return c_->Calibrate(id_, params);
  }
  absl::StatusOr<GradCheckReport> GradCheck(
      const SdfParams& params, const GradCheckOptions& options,
      const ComputeControl& control) override {
    auto r = c_->GradCheck(id_, params, options, control.progress);
    if (!r.ok()) return r.status();
    return std::move(r->report);
  }

 private:
  std::shared_ptr<client::RemoteClient> c_;
  const std::string id_;
  const bool temporary_;
  const Mesh mesh_;
  const ProgressMode progress_;
  const int fan_out_;  // sample ranges per pass and VJP.
  SdfParams params_;
  // The positions of Sdf()'s pass: the VJP and the penalty are asked for at
  // that generation, so that a session another client moved in between
  // fails ABORTED instead of answering for other positions.
  std::optional<int64_t> generation_;
  std::optional<SparseJacobian> jacobian_;
};

// The session `id` when it exists and holds a mesh of the same counts.
absl::Status CheckSession(const wire::SessionInfo& s, const Mesh& mesh) {
  if (s.dimension == mesh.dimension && s.num_vertices == mesh.num_vertices() &&
      s.num_faces == mesh.num_faces()) {
    return absl::OkStatus();
  }
  return absl::FailedPreconditionError(absl::StrCat(
      "session '", s.session_id, "' holds a ", s.dimension, "D mesh of ",
      s.num_vertices, " vertices and ", s.num_faces,
      " faces, not the given mesh (", mesh.dimension, "D, ",
      mesh.num_vertices(), " vertices, ", mesh.num_faces(), " faces)"));
}

}  // namespace

absl::StatusOr<std::unique_ptr<client::RemoteClient>> Connect(
    const RemoteFlags& remote) {
  client::ClientOptions options;
  if (remote.connect_timeout > 0) {
    options.connect_timeout_seconds = remote.connect_timeout;
  }
  if (absl::Status s = client::LoadClientSecrets(
          remote.tls_ca_file, remote.tls_cert_file, remote.tls_key_file,
          remote.token_file, &options);
      !s.ok()) {
    return s;
  }
  if (options.tls_ca_pem.empty() &&
      !(options.tls_cert_pem.empty() && options.tls_key_pem.empty())) {
    return absl::InvalidArgumentError(
        "--tls-cert-file/--tls-key-file need --tls-ca-file");
  }
  return std::make_unique<client::RemoteClient>(remote.server, options);
}

absl::StatusOr<BackendFactory> RemoteBackend(const RemoteFlags& remote,
                                             const std::string& session_id,
                                             ProgressMode progress,
                                             int fan_out) {
  auto connected = Connect(remote);
  if (!connected.ok()) return connected.status();
  std::shared_ptr<client::RemoteClient> c = std::move(*connected);
  return BackendFactory(
      [c, session_id, progress,
       fan_out](Mesh mesh) -> absl::StatusOr<std::unique_ptr<Backend>> {
        if (!session_id.empty()) {
          auto info = c->Get(session_id);
          if (info.ok()) {
            if (absl::Status s = CheckSession(*info, mesh); !s.ok()) return s;
            return std::make_unique<Remote>(c, session_id, false,
                                            std::move(mesh), progress, fan_out);
          }
          if (info.status().code() != absl::StatusCode::kNotFound) {
            return info.status();
          }
        }
        auto up = c->Upload(mesh, session_id);
        if (!up.ok()) return up.status();
        return std::make_unique<Remote>(c, up->session_id, session_id.empty(),
                                        std::move(mesh), progress, fan_out);
      });
}

}  // namespace meshgauge::cli

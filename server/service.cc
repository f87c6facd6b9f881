#include "server/service.h"

#include "absl/time/time.h"

#include <chrono>
#include <memory>
#include <optional>

#include "absl/strings/str_cat.h"
#include "lib/core/stopwatch.h"
#include "proto/wire/convert.h"
#include "proto/wire/gradcheck_convert.h"
#include "proto/wire/reply_bytes.h"
#include "proto/wire/reply_convert.h"

namespace meshgauge::server {
namespace {

constexpr double kProgressIntervalSeconds = 0.25;

// The metric label of a status: Abseil's name of the code (gRPC's codes are
// Abseil's), "UNKNOWN" for a number outside them (a bounded label set).
std::string CodeName(grpc::StatusCode code) {
  std::string name =
      absl::StatusCodeToString(static_cast<absl::StatusCode>(code));
  return name.empty() ? "UNKNOWN" : name;
}

// A CallControl::progress that streams SdfProgress messages to `writer`:
// at most one every kProgressIntervalSeconds, and the last one (the
// evaluator serialises the calls).
template <typename Response>
std::function<void(const CallProgress&)> ProgressWriter(
    grpc::ServerWriter<Response>* writer) {
  // Since the last write; none before the first.
  auto last = std::make_shared<std::optional<Stopwatch>>();
  return [writer, last](const CallProgress& progress) {
    if (progress.vertices_done < progress.vertices_total && last->has_value() &&
        (*last)->Seconds() < kProgressIntervalSeconds) {
      return;
    }
    last->emplace();
    Response msg;
    v1::SdfProgress* p = msg.mutable_progress();
    p->set_vertices_done(progress.vertices_done);
    p->set_vertices_total(progress.vertices_total);
    p->set_rays_total(progress.rays_total);
    writer->Write(msg);  // a client gone is seen by the cancellation hook.
  };
}

// A CallControl of ctx's cancellation and deadline.
CallControl Control(grpc::ServerContext* ctx) {
  CallControl control;
  control.cancelled = [ctx] { return ctx->IsCancelled(); };
  control.deadline = ctx->deadline();
  return control;
}

// The same, streaming progress to `writer` when the request asks for it.
template <typename Request, typename Response>
CallControl Control(grpc::ServerContext* ctx, const Request& request,
                    grpc::ServerWriter<Response>* writer) {
  CallControl control = Control(ctx);
  if (request.report_progress()) control.progress = ProgressWriter(writer);
  return control;
}

// A compute request's session, positions and parameters (the parameters
// checked against the server's limits), with its sample range when the
// request has one (ComputeSdf, ComputeVjp, ComputePenalty).
template <typename Request>
absl::StatusOr<SessionTarget> TargetFromWire(const Request& request,
                                             const ServerOptions& options) {
  auto params = wire::FromWire(request.params(), options.max_rays);
  if (!params.ok()) return params.status();
  if constexpr (requires { request.range(); }) {
    if (request.has_range()) {
      auto range = wire::FromWire(request.range());
      if (!range.ok()) return range.status();
      params->range = *range;
    }
  }
  SessionTarget target{request.session_id(), *params, std::nullopt};
  if (request.has_expected_generation()) {
    target.expected_generation = request.expected_generation();
  }
  return target;
}

}  // namespace

MeshGaugeService::MeshGaugeService(const ServerOptions& options,
                                   SessionStore* store, UploadWatch* uploads,
                                   const Authenticator* auth, Metrics* metrics,
                                   const Clock* clock)
    : options_(options),
      store_(store),
      auth_(auth),
      metrics_(metrics),
      clock_(clock),
      calls_(options, store, metrics),
      reception_(options, store, uploads, clock) {}

template <typename Body>
grpc::Status MeshGaugeService::Instrumented(const char* method,
                                            const grpc::ServerContextBase* ctx,
                                            Body body) {
  const Stopwatch start;
  {
    absl::MutexLock lock(&drain_mu_);
    if (draining_) {
      const grpc::Status refused(
          grpc::StatusCode::UNAVAILABLE,
          "meshgauge-server is draining (shutting down): retry; with a "
          "session store any other replica serves the session");
      metrics_->RecordRpc(method, CodeName(refused.error_code()),
                          start.Seconds());
      return refused;
    }
    ++in_flight_;
  }
  // A client's retry policy marks its retried attempts.
  if (ctx->client_metadata().count("grpc-previous-rpc-attempts")) {
    metrics_->RecordRetriedAttempt(method);
  }
  store_->Sweep();
  auto tenant = auth_->Authenticate(*ctx);
  grpc::Status status =
      wire::ToGrpc(tenant.ok() ? body(*tenant) : tenant.status());
  metrics_->RecordRpc(method, CodeName(status.error_code()), start.Seconds());
  LeaveInFlight();
  return status;
}

void MeshGaugeService::EnterInFlight() {
  absl::MutexLock lock(&drain_mu_);
  ++in_flight_;
}

void MeshGaugeService::LeaveInFlight() {
  absl::MutexLock lock(&drain_mu_);
  --in_flight_;
}

void MeshGaugeService::Drain(std::chrono::system_clock::time_point deadline) {
  absl::MutexLock lock(&drain_mu_);
  draining_ = true;
  // absl::Mutex evaluates the condition whenever drain_mu_ is released.
  drain_mu_.AwaitWithDeadline(
      absl::Condition(this, &MeshGaugeService::Drained),
      absl::FromChrono(deadline));
}

grpc::ServerReadReactor<grpc::ByteBuffer>* MeshGaugeService::CreateSession(
    grpc::CallbackServerContext* ctx, grpc::ByteBuffer* response) {
  return upload_calls_.Start(
      ctx, response,
      [this](UploadCall& call, v1::CreateSessionResponse* response) {
        return ServeUpload(call, response);
      });
}

grpc::Status MeshGaugeService::ServeUpload(
    UploadCall& call, v1::CreateSessionResponse* response) {
  grpc::Status status = Instrumented(
      "CreateSession", call.context(),
      [&](const std::string& tenant) -> absl::Status {
        auto created = reception_.Receive(call, tenant);
        if (!created.ok()) return created.status();
        response->mutable_welded_vertex()->Assign(
            created->welded_vertex.begin(), created->welded_vertex.end());
        wire::ToWire(created->session, response->mutable_session());
        return absl::OkStatus();
      });
  if (!status.ok() && !call.ended()) {
    EnterInFlight();
    reception_.DiscardRest(call);
    LeaveInFlight();
  }
  return status;
}

grpc::Status MeshGaugeService::GetSession(grpc::ServerContext* ctx,
                                          const v1::GetSessionRequest* request,
                                          v1::GetSessionResponse* response) {
  return Instrumented(
      "GetSession", ctx, [&](const std::string& tenant) -> absl::Status {
        auto session =
            store_->Get(tenant, request->session_id(), /*touch=*/false);
        if (!session.ok()) return session.status();
        wire::ToWire(
            ToSessionInfo((*session)->Snapshot(), clock_->NowSeconds()),
            response->mutable_session());
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::ListSessions(
    grpc::ServerContext* ctx, const v1::ListSessionsRequest* request,
    v1::ListSessionsResponse* response) {
  return Instrumented(
      "ListSessions", ctx, [&](const std::string& tenant) -> absl::Status {
        int page_size = request->page_size() == 0 ? 100 : request->page_size();
        if (page_size < 1 || page_size > 1000) {
          return absl::InvalidArgumentError(absl::StrCat(
              "page_size must be in [1, 1000] (0 = 100), got ", page_size));
        }
        std::string next;
        const double now = clock_->NowSeconds();
        auto page =
            store_->List(tenant, request->page_token(), page_size, &next);
        if (!page.ok()) return page.status();
        for (const SessionSnapshot& s : *page) {
          wire::ToWire(ToSessionInfo(s, now), response->add_sessions());
        }
        response->set_next_page_token(next);
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::DeleteSession(
    grpc::ServerContext* ctx, const v1::DeleteSessionRequest* request,
    v1::DeleteSessionResponse*) {
  return Instrumented("DeleteSession", ctx,
                      [&](const std::string& tenant) -> absl::Status {
                        return store_->Delete(tenant, request->session_id());
                      });
}

grpc::Status MeshGaugeService::UpdatePositions(
    grpc::ServerContext* ctx, const v1::UpdatePositionsRequest* request,
    v1::UpdatePositionsResponse* response) {
  return Instrumented(
      "UpdatePositions", ctx, [&](const std::string& tenant) -> absl::Status {
        auto session = store_->Get(tenant, request->session_id());
        if (!session.ok()) return session.status();
        const int dim = (*session)->dimension();
        auto points = wire::ToPoints(request->positions(), dim, "positions");
        if (!points.ok()) return points.status();
        const bool subset = request->indices_size() > 0;
        const int64_t expected =
            subset ? request->indices_size() : (*session)->num_vertices();
        if (absl::Status c =
                CheckPointCount(std::ssize(*points), expected, subset);
            !c.ok()) {
          return c;
        }
        std::vector<int32_t> indices(request->indices().begin(),
                                     request->indices().end());
        auto outcome = store_->UpdatePositions(
            tenant, *session, request->expected_generation(), indices, *points,
            {.deadline = ctx->deadline(),
             .cancelled = [ctx] { return ctx->IsCancelled(); }});
        if (!outcome.ok()) return outcome.status();
        wire::ToWire(*outcome, response);
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::ComputeSdf(
    grpc::ServerContext* ctx, const v1::ComputeSdfRequest* request,
    grpc::ServerWriter<v1::ComputeSdfResponse>* writer) {
  return Instrumented(
      "ComputeSdf", ctx, [&](const std::string& tenant) -> absl::Status {
        const Stopwatch start;
        auto chunk = wire::ChunkSamplesFromWire(request->chunk_vertices());
        if (!chunk.ok()) return chunk.status();
        auto target = TargetFromWire(*request, options_);
        if (!target.ok()) return target.status();
        const CallControl control = Control(ctx, *request, writer);
        // The outcome holds no session lock: a client that stops reading the
        // stream holds back no update.
        auto sdf =
            calls_.Sdf(tenant, *target, request->include_jacobian(), control);
        if (!sdf.ok()) return sdf.status();
        const SdfResult& r = sdf->pass->result;
        const SparseJacobian* jacobian =
            sdf->jacobian ? &*sdf->jacobian : nullptr;
        const wire::SdfChunker chunker(jacobian, sdf->dimension,
                                       std::ssize(r.values), *chunk,
                                       options_.max_message_bytes);
        if (absl::Status s = chunker.CheckRows(); !s.ok()) return s;
        v1::ComputeSdfResponse last;
        wire::ToWireSummary(r, sdf->integral, sdf->facts,
                            last.mutable_summary());
        for (std::string& w : sdf->warnings) {
          last.mutable_summary()->add_warnings(std::move(w));
        }
        for (int64_t begin = 0, end = 0; begin < std::ssize(r.values);
             begin = end) {
          if (ctx->IsCancelled()) {
            return control.Interrupted(absl::CancelledError("cancelled"));
          }
          end = chunker.ChunkEnd(begin);
          v1::ComputeSdfResponse msg;
          wire::ToWireChunk(r, jacobian, sdf->dimension, begin, end,
                            msg.mutable_chunk());
          if (!writer->Write(msg)) {
            return absl::CancelledError("client went away during the stream");
          }
        }
        last.mutable_summary()->set_seconds(start.Seconds());
        if (!writer->Write(last)) {
          return absl::CancelledError("client went away before the summary");
        }
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::ComputeVjp(grpc::ServerContext* ctx,
                                          const v1::ComputeVjpRequest* request,
                                          v1::ComputeVjpResponse* response) {
  return Instrumented(
      "ComputeVjp", ctx, [&](const std::string& tenant) -> absl::Status {
        auto target = TargetFromWire(*request, options_);
        if (!target.ok()) return target.status();
        auto vjp = calls_.Vjp(tenant, *target,
                              absl::MakeConstSpan(request->weights().data(),
                                                  request->weights_size()),
                              Control(ctx));
        if (!vjp.ok()) return vjp.status();
        wire::ToWire(vjp->reply, vjp->dimension, response);
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::ComputePenalty(
    grpc::ServerContext* ctx, const v1::ComputePenaltyRequest* request,
    v1::ComputePenaltyResponse* response) {
  return Instrumented(
      "ComputePenalty", ctx, [&](const std::string& tenant) -> absl::Status {
        auto penalty = wire::PenaltyFromWire(*request);
        if (!penalty.ok()) return penalty.status();
        auto thin = wire::ThinFromWire(*request);
        if (!thin.ok()) return thin.status();
        auto target = TargetFromWire(*request, options_);
        if (!target.ok()) return target.status();
        auto out = calls_.Penalty(
            tenant, *target, *penalty, *thin, request->with_gradient(),
            Control(ctx),
            absl::MakeConstSpan(request->values().data(),
                                request->values_size()));
        if (!out.ok()) return out.status();
        if (out->thin) {
          wire::ToWire(*out->thin, (*thin)->max_regions,
                       response->mutable_thin());
        }
        wire::ToWire(out->reply, out->dimension, request->with_gradient(),
                     response);
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::Calibrate(grpc::ServerContext* ctx,
                                         const v1::CalibrateRequest* request,
                                         v1::CalibrateResponse* response) {
  return Instrumented(
      "Calibrate", ctx, [&](const std::string& tenant) -> absl::Status {
        auto sdf = wire::FromWire(request->params(), options_.max_rays);
        if (!sdf.ok()) return sdf.status();
        auto report = calls_.Calibrate(
            tenant, request->session_id(),
            wire::CalibrationFromWire(*request, *sdf), Control(ctx));
        if (!report.ok()) return report.status();
        wire::ToWire(*report, response);
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::GetServerInfo(
    grpc::ServerContext* ctx, const v1::GetServerInfoRequest*,
    v1::GetServerInfoResponse* response) {
  return Instrumented(
      "GetServerInfo", ctx, [&](const std::string&) -> absl::Status {
        wire::ToWire(
            wire::ServerInfo{
                .version = MESHGAUGE_VERSION,
                .api = "meshgauge.v1",
                .max_rays = options_.max_rays,
                .max_vertices = options_.max_vertices,
                .max_faces = options_.max_faces,
                .max_message_bytes = options_.max_message_bytes,
                .max_upload_message_bytes = options_.max_upload_message_bytes,
                .max_upload_file_bytes = MaxUploadFileBytes(options_),
                .max_sessions = options_.SessionsPerTenant(),
                .memory_budget_bytes = options_.BudgetPerTenant()},
            response);
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::GetMesh(grpc::ServerContext* ctx,
                                       const v1::GetMeshRequest* request,
                                       v1::GetMeshResponse* response) {
  return Instrumented(
      "GetMesh", ctx, [&](const std::string& tenant) -> absl::Status {
        auto view = calls_.GetMesh(tenant, request->session_id());
        if (!view.ok()) return view.status();
        wire::ToWire(view->mesh(), view->reader.generation(), response);
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::GradCheck(
    grpc::ServerContext* ctx, const v1::GradCheckRequest* request,
    grpc::ServerWriter<v1::GradCheckResponse>* writer) {
  return Instrumented(
      "GradCheck", ctx, [&](const std::string& tenant) -> absl::Status {
        const Stopwatch start;
        auto options = wire::GradCheckFromWire(*request);
        if (!options.ok()) return options.status();
        auto target = TargetFromWire(*request, options_);
        if (!target.ok()) return target.status();
        const CallControl control = Control(ctx, *request, writer);
        auto check = calls_.GradCheck(tenant, *target, *options, control);
        if (!check.ok()) return check.status();
        v1::GradCheckResponse msg;
        wire::ToWire(check->report, check->facts.generation,
                     msg.mutable_report());
        msg.mutable_report()->set_seconds(start.Seconds());
        if (absl::Status s =
                wire::CheckGradCheckBytes(msg, options_.max_message_bytes);
            !s.ok()) {
          return s;
        }
        if (!writer->Write(msg)) {
          return absl::CancelledError("client went away before the report");
        }
        return absl::OkStatus();
      });
}

}  // namespace meshgauge::server

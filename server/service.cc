#include "server/service.h"

#include <malloc.h>

#include <chrono>
#include <cmath>
#include <iostream>
#include <optional>

#include "absl/strings/str_cat.h"
#include "lib/core/face_sample.h"
#include "lib/core/integrals.h"
#include "lib/core/missing_diagnosis.h"
#include "lib/core/penalty.h"
#include "lib/core/sensitivity.h"
#include "lib/core/thin_regions.h"
#include "lib/embree/calibration.h"
#include "lib/embree/gradcheck.h"
#include "lib/embree/ray_scene.h"
#include "lib/io/mesh_io.h"
#include "proto/wire/convert.h"
#include "proto/wire/gradcheck_convert.h"
#include "proto/wire/reply_convert.h"
#include "server/session_store.h"

namespace meshgauge::server {
namespace {

constexpr int kDefaultChunkVertices = 16384;
constexpr auto kProgressInterval = std::chrono::milliseconds(250);
// A refused upload that received more than this returns its memory.
constexpr int64_t kTrimAfterBytes = 1ll << 20;
constexpr int kMaxChunkVertices = 65536;

// The metric label of a status: Abseil's name of the code (gRPC's codes are
// Abseil's), "UNKNOWN" for a number outside them (a bounded label set).
std::string CodeName(grpc::StatusCode code) {
  std::string name =
      absl::StatusCodeToString(static_cast<absl::StatusCode>(code));
  return name.empty() ? "UNKNOWN" : name;
}

// An upload the server ended for one of its limits (size, rate, deadline,
// memory): logged with what the client had sent.
bool IsUploadLimit(const absl::Status& s) {
  return s.code() == absl::StatusCode::kDeadlineExceeded ||
         s.code() == absl::StatusCode::kResourceExhausted;
}

int64_t FullPassRays(const SdfEvaluator& ev, const SdfParams& params) {
  return NumSamples(ev.mesh(), params.samples) *
         int64_t{ResolveParams(params, ev.mesh().dimension).rays};
}

double Seconds(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

MeshGaugeService::MeshGaugeService(const ServerOptions& options,
                                   SessionStore* store, UploadWatch* uploads,
                                   const Authenticator* auth, Metrics* metrics,
                                   const Clock* clock)
    : options_(options),
      store_(store),
      uploads_(uploads),
      auth_(auth),
      metrics_(metrics),
      clock_(clock),
      slots_(options.ComputationsPerTenant(),
             options.ConcurrentComputations()) {
  // Method 0 of the generated service is CreateSession (the proto's first
  // rpc): its handler reads UploadMessage instead of the parsed request.
  MarkMethodStreamed(
      0, new grpc::internal::ClientStreamingHandler<
             MeshGaugeService, UploadMessage, v1::CreateSessionResponse>(
             [](MeshGaugeService* service, grpc::ServerContext* ctx,
                grpc::ServerReader<UploadMessage>* reader,
                v1::CreateSessionResponse* response) {
               return service->BoundedCreateSession(ctx, reader, response);
             },
             this));
}

absl::Status MeshGaugeService::CheckReplySize(int64_t values) const {
  // Packed doubles plus a small envelope.
  const int64_t bytes = values * 8 + 256;
  if (bytes <= options_.max_message_bytes) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrCat(
      "the reply would be about ", bytes, " bytes, over the server's limit of ",
      options_.max_message_bytes,
      " bytes (--max_message_bytes); refused "
      "before computing"));
}

template <typename Body>
grpc::Status MeshGaugeService::Instrumented(const char* method,
                                            const grpc::ServerContext* ctx,
                                            Body body) {
  const auto start = std::chrono::steady_clock::now();
  {
    std::lock_guard<std::mutex> lock(drain_mu_);
    if (draining_) {
      const grpc::Status refused(
          grpc::StatusCode::UNAVAILABLE,
          "meshgauge-server is draining (shutting down): retry; with a "
          "session store any other replica serves the session");
      metrics_->RecordRpc(method, CodeName(refused.error_code()),
                          Seconds(start));
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
  metrics_->RecordRpc(method, CodeName(status.error_code()), Seconds(start));
  LeaveInFlight();
  return status;
}

void MeshGaugeService::LeaveInFlight() {
  {
    std::lock_guard<std::mutex> lock(drain_mu_);
    --in_flight_;
  }
  drain_cv_.notify_all();
}

void MeshGaugeService::Drain(std::chrono::system_clock::time_point deadline) {
  std::unique_lock<std::mutex> lock(drain_mu_);
  draining_ = true;
  drain_cv_.wait_until(lock, deadline, [this] { return in_flight_ == 0; });
}

ComputeControl MeshGaugeService::Control(grpc::ServerContext* ctx) const {
  ComputeControl control;
  control.cancelled = [ctx] { return ctx->IsCancelled(); };
  return control;
}

template <typename Response>
std::function<void(int64_t, int64_t)> MeshGaugeService::ProgressWriter(
    int64_t rays_total, grpc::ServerWriter<Response>* writer) {
  // The evaluator serialises progress calls; at most one write every
  // kProgressInterval, and the last one.
  auto last = std::make_shared<std::chrono::steady_clock::time_point>();
  return [writer, rays_total, last](int64_t done, int64_t total) {
    const auto now = std::chrono::steady_clock::now();
    if (done < total && now - *last < kProgressInterval) return;
    *last = now;
    Response msg;
    v1::SdfProgress* p = msg.mutable_progress();
    p->set_vertices_done(done);
    p->set_vertices_total(total);
    p->set_rays_total(rays_total);
    writer->Write(msg);  // a client gone is seen by the cancellation hook.
  };
}

absl::Status MeshGaugeService::Interrupted(grpc::ServerContext* ctx,
                                           absl::Status s) const {
  if (s.code() != absl::StatusCode::kCancelled) return s;
  if (ctx->deadline() <= std::chrono::system_clock::now()) {
    return absl::DeadlineExceededError("deadline exceeded during computation");
  }
  return absl::CancelledError("call cancelled by the client");
}

absl::StatusOr<MeshGaugeService::Prepared> MeshGaugeService::Prepare(
    grpc::ServerContext* ctx, const std::string& tenant,
    const std::string& session_id, const v1::SdfParameters& params,
    bool has_expected_generation, int64_t expected_generation) {
  // The slot first: a queued call holds no session lock.
  auto slot = TakeSlot(tenant, ctx);
  if (!slot.ok()) return slot.status();
  auto session = store_->Get(tenant, session_id);
  if (!session.ok()) return session.status();
  auto sdf_params =
      wire::FromWire(params, options_.max_rays, options_.compute_threads);
  if (!sdf_params.ok()) return sdf_params.status();
  auto reader = (*session)->Read();
  if (!reader.ok()) return reader.status();
  const int64_t generation = reader->evaluator->generation();
  if (has_expected_generation && expected_generation != generation) {
    return GenerationMismatch(session_id, generation, expected_generation,
                              "request");
  }
  return Prepared{std::move(*slot), std::move(*session), std::move(*reader),
                  *sdf_params};
}

absl::StatusOr<ComputeSlots::Slot> MeshGaugeService::TakeSlot(
    const std::string& tenant, grpc::ServerContext* ctx) {
  auto slot = slots_.Take(tenant, [ctx] {
    return ctx->IsCancelled() ||
           std::chrono::system_clock::now() >= ctx->deadline();
  });
  if (!slot.ok()) return Interrupted(ctx, slot.status());
  return slot;
}

absl::StatusOr<MeshGaugeService::Pass> MeshGaugeService::EnsurePass(
    grpc::ServerContext* ctx, const std::string& tenant, const Prepared& prep,
    const ComputeControl& control) {
  const SdfEvaluator& ev = *prep.reader.evaluator;
  const SdfParams& params = prep.params;
  Session& session = *prep.session;
  if (auto cached = session.FindPass(params, ev.generation())) {
    return Pass{std::move(cached), true};
  }
  // Counted in the session's memory once stored; until then a claim.
  auto claim = store_->ClaimScratch(tenant, prep.session,
                                    EstimatePassBytes(ev.mesh(), params),
                                    "this ray pass's hit table and values");
  if (!claim.ok()) return claim.status();
  // The rays of the session's last pass with these parameters (an earlier
  // generation's) are reused where they cannot have changed.
  const std::shared_ptr<const CachedPass> last = session.LatestPass(params);
  const PreviousPass previous{last ? &last->result : nullptr,
                              last ? &last->hits : nullptr};
  auto pass = std::make_shared<CachedPass>();
  auto result = ev.Compute(params, control, &pass->hits, &previous);
  if (!result.ok()) return Interrupted(ctx, result.status());
  metrics_->AddRays(static_cast<double>(result->rays_traced));
  pass->params = params;
  pass->generation = ev.generation();
  pass->result = std::move(*result);
  pass->bytes = PassBytes(pass->result, pass->hits);
  session.StorePass(pass);
  claim->reset();  // the session's memory now counts the pass.
  store_->EnforceBudget(&session);
  return Pass{std::move(pass), false};
}

grpc::Status MeshGaugeService::BoundedCreateSession(
    grpc::ServerContext* ctx, grpc::ServerReader<UploadMessage>* reader,
    v1::CreateSessionResponse* response) {
  UploadProgress progress;
  grpc::Status status = Instrumented(
      "CreateSession", ctx, [&](const std::string& tenant) -> absl::Status {
        auto upload = uploads_->Start(ctx);
        if (!upload.ok()) return upload.status();
        absl::Status s =
            ReceiveUpload(ctx, reader, tenant, *upload, response, &progress);
        if (absl::Status aborted = uploads_->Finish(*upload); !aborted.ok()) {
          s = aborted;
        }
        // A refused upload that received over 1 MiB: give the freed pages
        // back to the system (trimming takes every arena's lock, so not for
        // small ones).
        if (!s.ok() && progress.received > kTrimAfterBytes) malloc_trim(0);
        if (IsUploadLimit(s)) {
          std::cerr << "meshgauge-server: CreateSession ended after "
                    << progress.received << " bytes: " << s.message()
                    << std::endl;
        }
        return s;
      });
  if (!status.ok() && !progress.ended) DiscardRest(ctx, reader);
  return status;
}

void MeshGaugeService::DiscardRest(grpc::ServerContext* ctx,
                                   grpc::ServerReader<UploadMessage>* reader) {
  if (ctx->IsCancelled()) return;
  auto discard = uploads_->StartDiscard(ctx);
  if (!discard.ok()) return;
  {  // A drain waits for it like a call.
    std::lock_guard<std::mutex> lock(drain_mu_);
    ++in_flight_;
  }
  UploadMessage message(/*limit=*/0);  // no message is parsed.
  while (reader->Read(&message) &&
         uploads_->Touch(*discard, message.received_bytes).ok()) {
  }
  (void)uploads_->Finish(*discard);
  LeaveInFlight();
}

absl::StatusOr<RepairedMesh> MeshGaugeService::BuildUploadedMesh(
    grpc::ServerContext* ctx, MeshAssembler& assembler,
    UploadReservation& ticket) const {
  // Within the server's limits, stopping (between polygons, and every
  // 65,536 faces) when the caller is gone. A file's reader reserves what it
  // holds beyond the header's estimate as it grows (a file's size says
  // little about its mesh); arrays were reserved by their declared counts.
  const int64_t buffered = assembler.bytes_held();
  io::ReadLimits limits{.max_vertices = options_.max_vertices,
                        .max_faces = options_.max_faces,
                        .max_fallback_work = kMaxUploadFallbackWork,
                        .cancelled = [ctx] { return ctx->IsCancelled(); }};
  if (assembler.file_upload()) {
    limits.reserve = [&](int64_t bytes) {
      return ticket.GrowTo(buffered + bytes);
    };
  }
  auto file = assembler.Finish(limits);
  if (!file.ok()) return file.status();
  // The session's own estimate covers the repairs' transient arrays.
  if (absl::Status s = ticket.GrowTo(Session::EstimateBaseBytes(file->mesh));
      !s.ok()) {
    return s;
  }
  RepairOptions repairs = assembler.repairs();
  repairs.threads = options_.compute_threads;
  auto repaired = RepairFileMesh(std::move(*file), repairs);
  if (!repaired.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("CreateSession: ", repaired.status().message()));
  }
  // A mesh the ray tracer cannot take is refused now, not by every call.
  if (absl::Status s = CheckTraceable(repaired->mesh); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("CreateSession: ", s.message()));
  }
  return repaired;
}

absl::Status MeshGaugeService::ReceiveUpload(
    grpc::ServerContext* ctx, grpc::ServerReader<UploadMessage>* reader,
    const std::string& tenant, int64_t upload,
    v1::CreateSessionResponse* response, UploadProgress* progress) {
  MeshAssembler assembler(options_);
  UploadReservation ticket;
  bool reserved = false;
  UploadMessage message(options_.max_upload_message_bytes);
  while (reader->Read(&message)) {
    progress->received += message.received_bytes;
    if (!message.refused.empty()) {
      return absl::ResourceExhaustedError(message.refused);
    }
    if (absl::Status s = uploads_->Touch(upload, message.received_bytes);
        !s.ok()) {
      return s;
    }
    if (absl::Status s = assembler.Add(message.request); !s.ok()) return s;
    if (reserved) {
      if (absl::Status s = ticket.Arrived(assembler.bytes_held()); !s.ok()) {
        return s;
      }
    } else {
      // The header's declared size is claimed before any data is buffered.
      auto r = store_->Reserve(tenant, assembler.EstimatedBytes());
      if (!r.ok()) return r.status();
      ticket = std::move(*r);
      reserved = true;
    }
  }
  progress->ended = true;
  uploads_->Received(upload);
  if (ctx->IsCancelled()) return absl::CancelledError("upload cancelled");
  auto mesh = BuildUploadedMesh(ctx, assembler, ticket);
  if (!mesh.ok()) return mesh.status();
  // A caller that gave up (deadline, cancel) gets no orphan session.
  if (ctx->IsCancelled()) return absl::CancelledError("upload cancelled");
  const std::vector<int32_t> welded = std::move(mesh->weld.welded_vertex);
  auto session = store_->Create(tenant, assembler.session_id(),
                                std::move(*mesh), std::move(ticket));
  if (!session.ok()) return session.status();
  response->mutable_welded_vertex()->Assign(welded.begin(), welded.end());
  wire::ToWire(ToSessionInfo((*session)->Snapshot(), clock_->NowSeconds()),
               response->mutable_session());
  return absl::OkStatus();
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
        const auto start = std::chrono::steady_clock::now();
        int chunk = request->chunk_vertices() == 0 ? kDefaultChunkVertices
                                                   : request->chunk_vertices();
        if (chunk < 1 || chunk > kMaxChunkVertices) {
          return absl::InvalidArgumentError(
              absl::StrCat("chunk_vertices must be in [1, ", kMaxChunkVertices,
                           "] (0 = ", kDefaultChunkVertices, "), got ", chunk));
        }
        auto prep = Prepare(
            ctx, tenant, request->session_id(), request->params(),
            request->has_expected_generation(), request->expected_generation());
        if (!prep.ok()) return prep.status();
        ComputeControl control = Control(ctx);
        if (request->report_progress()) {
          control.progress = ProgressWriter(
              FullPassRays(*prep->reader.evaluator, prep->params), writer);
        }
        auto pass = EnsurePass(ctx, tenant, *prep, control);
        if (!pass.ok()) return pass.status();
        const SdfEvaluator& ev = *prep->reader.evaluator;
        const SdfResult& r = pass->pass->result;
        std::optional<SparseJacobian> jac;
        std::unique_ptr<ScratchClaim> jacobian_claim;  // until streamed.
        if (request->include_jacobian()) {
          auto bytes = JacobianBytesBound(ev, pass->pass->hits);
          if (!bytes.ok()) return bytes.status();
          auto claim = store_->ClaimScratch(tenant, prep->session, *bytes,
                                            "this Jacobian");
          if (!claim.ok()) return claim.status();
          jacobian_claim = std::move(*claim);
          auto j = ComputeJacobian(ev, pass->pass->hits, Control(ctx),
                                   options_.compute_threads);
          if (!j.ok()) return Interrupted(ctx, j.status());
          jac = std::move(*j);
        }
        const int64_t ns = std::ssize(r.values);  // samples: #V or #F.
        const int dim = ev.mesh().dimension;
        // Per sample about 30 bytes of values; per Jacobian entry 4 + 8 dim.
        const int64_t budget = options_.max_message_bytes / 2;
        auto sample_bytes = [&](int64_t p) {
          return 40 + (jac ? (jac->row_offsets[p + 1] - jac->row_offsets[p]) *
                                 (4 + 8 * dim)
                           : 0);
        };
        // A message holds at least one vertex: refuse before streaming when
        // one vertex's row cannot fit.
        for (int64_t p = 0; jac && p < ns; ++p) {
          if (sample_bytes(p) > budget) {
            return absl::ResourceExhaustedError(absl::StrCat(
                "sample ", p, "'s Jacobian row takes about ", sample_bytes(p),
                " bytes, more than half the message limit of ",
                options_.max_message_bytes,
                " bytes (--max_message_bytes); use fewer rays or ask for "
                "the VJP instead"));
          }
        }
        // The summary, then no more use of the session: its lock is let go
        // before streaming, so a client that stops reading the stream holds
        // back no update (the values are the cached pass's, kept by `pass`).
        v1::ComputeSdfResponse last;
        wire::ToWireSummary(r, IntegrateSdf(ev.mesh(), r).value,
                            {ev.generation(), pass->reused, Seconds(start)},
                            last.mutable_summary());
        // Without a topology pass unless the missing share of the surface
        // is over the warning's.
        for (std::string& w : MissingValueWarnings(ev.mesh(), r)) {
          last.mutable_summary()->add_warnings(std::move(w));
        }
        prep->reader.lock.unlock();
        prep->slot.Release();
        for (int64_t begin = 0, end = 0; begin < ns; begin = end) {
          if (ctx->IsCancelled()) {
            return Interrupted(ctx, absl::CancelledError("cancelled"));
          }
          end = std::min(ns, begin + chunk);
          // End the chunk early so that its values (and rows) fit in one
          // message.
          int64_t bytes = 0;
          for (int64_t p = begin; p < end; ++p) {
            bytes += sample_bytes(p);
            if (bytes > budget && p > begin) {
              end = p;
              break;
            }
          }
          v1::ComputeSdfResponse msg;
          wire::ToWireChunk(r, jac ? &*jac : nullptr, dim, begin, end,
                            msg.mutable_chunk());
          if (!writer->Write(msg)) {
            return absl::CancelledError("client went away during the stream");
          }
        }
        last.mutable_summary()->set_seconds(Seconds(start));
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
        const auto start = std::chrono::steady_clock::now();
        auto prep = Prepare(
            ctx, tenant, request->session_id(), request->params(),
            request->has_expected_generation(), request->expected_generation());
        if (!prep.ok()) return prep.status();
        const SdfEvaluator& ev = *prep->reader.evaluator;
        if (absl::Status s =
                CheckReplySize(ev.mesh().num_vertices() * ev.mesh().dimension);
            !s.ok()) {
          return s;
        }
        const int64_t samples = NumSamples(ev.mesh(), prep->params.samples);
        if (request->weights_size() != samples) {
          return absl::InvalidArgumentError(absl::StrCat(
              "weights holds ", request->weights_size(),
              " values, expected one per ", SampleName(prep->params.samples),
              " (", samples, ")"));
        }
        auto pass = EnsurePass(ctx, tenant, *prep, Control(ctx));
        if (!pass.ok()) return pass.status();
        metrics_->RecordHitCache(pass->reused);
        auto vjp =
            meshgauge::ComputeVjp(ev, pass->pass->hits,
                                  absl::MakeConstSpan(request->weights().data(),
                                                      request->weights_size()),
                                  Control(ctx), options_.compute_threads);
        if (!vjp.ok()) return Interrupted(ctx, vjp.status());
        wire::ToWire(
            wire::VjpReply{std::move(*vjp),
                           {ev.generation(), pass->reused, Seconds(start)}},
            ev.mesh().dimension, response);
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::ComputePenalty(
    grpc::ServerContext* ctx, const v1::ComputePenaltyRequest* request,
    v1::ComputePenaltyResponse* response) {
  return Instrumented(
      "ComputePenalty", ctx, [&](const std::string& tenant) -> absl::Status {
        const auto start = std::chrono::steady_clock::now();
        auto pp = wire::PenaltyFromWire(*request);
        if (!pp.ok()) return pp.status();
        auto thin_request = wire::ThinFromWire(*request);
        if (!thin_request.ok()) return thin_request.status();
        auto prep = Prepare(
            ctx, tenant, request->session_id(), request->params(),
            request->has_expected_generation(), request->expected_generation());
        if (!prep.ok()) return prep.status();
        const SdfEvaluator& ev = *prep->reader.evaluator;
        // A thin region is about 18 doubles on the wire (four points, five
        // scalars and their tags).
        constexpr int64_t kThinRegionDoubles = 18;
        const int64_t reply_values =
            (request->with_gradient()
                 ? ev.mesh().num_vertices() * ev.mesh().dimension
                 : 0) +
            (*thin_request ? (*thin_request)->max_regions * kThinRegionDoubles
                           : 0);
        if (absl::Status s = CheckReplySize(reply_values); !s.ok()) return s;
        auto pass = EnsurePass(ctx, tenant, *prep, Control(ctx));
        if (!pass.ok()) return pass.status();
        metrics_->RecordHitCache(pass->reused);
        const SdfResult& sdf = pass->pass->result;
        auto pen = meshgauge::ComputePenalty(
            ev, sdf, *pp,
            request->with_gradient() ? &pass->pass->hits : nullptr,
            Control(ctx), options_.compute_threads);
        if (!pen.ok()) return Interrupted(ctx, pen.status());
        if (*thin_request) {
          ThinRegionParams thin_params = (*thin_request)->params;
          thin_params.samples = prep->params.samples;
          auto thin = FindThinRegions(ev.mesh(), sdf.values, thin_params);
          if (!thin.ok()) return thin.status();
          wire::ToWire(*thin, (*thin_request)->max_regions,
                       response->mutable_thin());
        }
        wire::ToWire(
            wire::PenaltyReply{std::move(*pen),
                               SummarizeValues(sdf.values).min,
                               sdf.world_frame_vertices,
                               {ev.generation(), pass->reused, Seconds(start)}},
            ev.mesh().dimension, request->with_gradient(), response);
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::Calibrate(grpc::ServerContext* ctx,
                                         const v1::CalibrateRequest* request,
                                         v1::CalibrateResponse* response) {
  return Instrumented(
      "Calibrate", ctx, [&](const std::string& tenant) -> absl::Status {
        auto prep = Prepare(ctx, tenant, request->session_id(),
                            request->params(), false, 0);
        if (!prep.ok()) return prep.status();
        auto rep = meshgauge::Calibrate(
            *prep->reader.evaluator,
            wire::CalibrationFromWire(*request, prep->params), Control(ctx));
        if (!rep.ok()) return Interrupted(ctx, rep.status());
        wire::ToWire(*rep, response);
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
        auto session = store_->Get(tenant, request->session_id());
        if (!session.ok()) return session.status();
        auto reader = (*session)->Read();
        if (!reader.ok()) return reader.status();
        const Mesh& mesh = reader->evaluator->mesh();
        // Coordinates as doubles (8 bytes); varints of at most 1 byte per
        // size, 5 per index and 10 per (possibly negative) region.
        if (absl::Status s =
                CheckReplySize(mesh.num_vertices() * mesh.dimension +
                               (mesh.num_faces() * (1 + 4 * 5) +
                                std::ssize(mesh.face_regions) * 10) /
                                   8);
            !s.ok()) {
          return s;
        }
        wire::ToWire(mesh, reader->generation(), response);
        return absl::OkStatus();
      });
}

grpc::Status MeshGaugeService::GradCheck(
    grpc::ServerContext* ctx, const v1::GradCheckRequest* request,
    grpc::ServerWriter<v1::GradCheckResponse>* writer) {
  return Instrumented(
      "GradCheck", ctx, [&](const std::string& tenant) -> absl::Status {
        const auto start = std::chrono::steady_clock::now();
        auto options = wire::GradCheckFromWire(*request);
        if (!options.ok()) return options.status();
        auto prep = Prepare(
            ctx, tenant, request->session_id(), request->params(),
            request->has_expected_generation(), request->expected_generation());
        if (!prep.ok()) return prep.status();
        const int64_t generation = prep->reader.generation();
        const Mesh& mesh = prep->reader.evaluator->mesh();
        if (absl::Status s = ValidateGradCheck(mesh, prep->params, *options);
            !s.ok()) {
          return s;
        }
        const int64_t rays_total =
            GradCheckPasses(mesh, *options) *
            FullPassRays(*prep->reader.evaluator, prep->params);
        // The probes move the vertices of a private evaluator: its memory is
        // claimed before it is made, and the session's lock is released
        // once the mesh is copied (before the copy's BVH is built).
        auto claim =
            store_->ClaimScratch(tenant, prep->session,
                                 Session::EstimateBaseBytes(mesh) +
                                     GradCheckWorkBytes(mesh, prep->params),
                                 "this check's private copy of the mesh and "
                                 "its passes");
        if (!claim.ok()) return claim.status();
        Mesh copy = mesh;
        prep->reader.lock.unlock();  // updates of the session go on.
        auto ev = SdfEvaluator::Create(std::move(copy));
        if (!ev.ok()) return ev.status();
        ComputeControl control = Control(ctx);
        if (request->report_progress()) {
          control.progress = ProgressWriter(rays_total, writer);
        }
        auto rep = RunGradCheck(**ev, prep->params, *options, control);
        if (!rep.ok()) return Interrupted(ctx, rep.status());
        metrics_->AddRays(static_cast<double>(rep->rays_traced));
        v1::GradCheckResponse msg;
        wire::ToWire(*rep, generation, msg.mutable_report());
        msg.mutable_report()->set_seconds(Seconds(start));
        const int64_t bytes = static_cast<int64_t>(msg.ByteSizeLong());
        if (bytes > options_.max_message_bytes) {
          return absl::ResourceExhaustedError(absl::StrCat(
              "the report of ", rep->rows.size(), " entries takes ", bytes,
              " bytes, over the server's message limit of ",
              options_.max_message_bytes,
              " bytes (--max_message_bytes); ask for fewer samples"));
        }
        if (!writer->Write(msg)) {
          return absl::CancelledError("client went away before the report");
        }
        return absl::OkStatus();
      });
}

}  // namespace meshgauge::server

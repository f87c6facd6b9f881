#include "client/remote/remote_client.h"

#include <grpcpp/generic/generic_stub.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <future>
#include <mutex>
#include <random>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/remote/fan_out.h"
#include "lib/core/face_sample.h"
#include "lib/io/text_file.h"
#include "meshgauge/v1/service_config.h"
#include "proto/wire/convert.h"
#include "proto/wire/gradcheck_convert.h"
#include "proto/wire/reply_convert.h"
#include "proto/wire/upload_convert.h"

namespace meshgauge::client {

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
  return absl::StrFormat(
      "%08x-%04x-4%03x-%04x-%012x", hi >> 32, (hi >> 16) & 0xffff, hi & 0xfff,
      0x8000 | ((lo >> 48) & 0x3fff), lo & 0xffffffffffffull);
}

RemoteClient::RemoteClient(const std::string& target, ClientOptions options)
    : options_(options), target_(target) {
  grpc::ChannelArguments args;
  if (options.retry) {
    args.SetServiceConfigJSON(v1::kServiceConfigJson);
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

absl::Status RemoteClient::Checked(const grpc::Status& s) const {
  absl::Status status = wire::FromGrpc(s);
  if (status.code() != absl::StatusCode::kUnavailable) return status;
  return absl::UnavailableError(absl::StrCat(
      "the meshgauge server at ", target_,
      " is unavailable (not running, unreachable, or refusing connections; "
      "retried for about ",
      static_cast<int>(std::min(options_.connect_timeout_seconds,
                                options_.deadline_seconds) +
                       5),
      " s): ", status.message()));
}

std::unique_ptr<grpc::ClientContext> RemoteClient::Context(
    const std::string& session_id, SampleRange range, int part) const {
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
  if (!range.all()) {
    ctx->AddMetadata(kRangeMetadataKey,
                     absl::StrCat(range.begin, "-", range.end));
  }
  if (part >= 0) ctx->AddMetadata(kPartMetadataKey, absl::StrCat(part));
  return ctx;
}

absl::StatusOr<wire::SessionInfo> RemoteClient::Upload(
    const Mesh& mesh, const std::string& requested_id) {
  const std::string session_id =
      requested_id.empty() ? NewSessionId() : requested_id;
  auto ctx = Context(session_id);
  v1::CreateSessionResponse response;
  auto writer = stub_->CreateSession(ctx.get(), &response);
  // A refused write ends the stream; Finish says why.
  wire::WriteUpload(mesh, session_id, options_.upload_chunk_vertices,
                    [&writer](const v1::CreateSessionRequest& m) {
                      return writer->Write(m);
                    });
  writer->WritesDone();
  absl::Status s = Checked(writer->Finish());
  if (s.code() == absl::StatusCode::kCancelled) {
    // This client cancels no upload: the server stopped it.
    return absl::CancelledError(absl::StrCat(
        "the server cancelled the upload: it stops an upload silent for "
        "longer than its --upload_idle_seconds (30 s by default), and cancels "
        "calls when it shuts down; its log names which: ",
        s.message()));
  }
  if (!s.ok()) return s;
  return wire::FromWire(response.session());
}

absl::StatusOr<wire::ServerInfo> RemoteClient::GetServerInfo() {
  auto ctx = Context("");
  v1::GetServerInfoRequest req;
  v1::GetServerInfoResponse resp;
  if (absl::Status s =
          Checked(stub_->GetServerInfo(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return wire::FromWire(resp);
}

absl::StatusOr<bool> RemoteClient::Serving() {
  // The health protocol as bytes (no generated health stubs): the request
  // is empty.
  grpc::GenericStub stub(channel_);
  auto ctx = Context("");
  grpc::Slice empty("");
  grpc::ByteBuffer request(&empty, 1), response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(ctx.get(), "/grpc.health.v1.Health/Check", grpc::StubOptions(),
                 &request, &response,
                 [&done](grpc::Status s) { done.set_value(std::move(s)); });
  if (absl::Status s = Checked(done.get_future().get()); !s.ok())
    return s;
  std::vector<grpc::Slice> slices;
  if (!response.Dump(&slices).ok()) {
    return absl::DataLossError("unreadable health response");
  }
  std::string bytes;
  for (const auto& s : slices) bytes.append(s.begin(), s.end());
  return wire::ServingFromHealthBytes(bytes);
}

absl::StatusOr<wire::SessionInfo> RemoteClient::Get(const std::string& id) {
  auto ctx = Context(id);
  v1::GetSessionRequest req;
  req.set_session_id(id);
  v1::GetSessionResponse resp;
  if (absl::Status s = Checked(stub_->GetSession(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return wire::FromWire(resp.session());
}

absl::StatusOr<std::vector<wire::SessionInfo>> RemoteClient::List(
    int page_size) {
  std::vector<wire::SessionInfo> all;
  v1::ListSessionsRequest req;
  req.set_page_size(page_size);
  do {
    auto ctx = Context("");
    v1::ListSessionsResponse resp;
    if (absl::Status s =
            Checked(stub_->ListSessions(ctx.get(), req, &resp));
        !s.ok()) {
      return s;
    }
    for (const v1::SessionInfo& info : resp.sessions()) {
      all.push_back(wire::FromWire(info));
    }
    req.set_page_token(resp.next_page_token());
  } while (!req.page_token().empty());
  return all;
}

absl::Status RemoteClient::Delete(const std::string& id) {
  auto ctx = Context(id);
  v1::DeleteSessionRequest req;
  req.set_session_id(id);
  v1::DeleteSessionResponse resp;
  return Checked(stub_->DeleteSession(ctx.get(), req, &resp));
}

absl::StatusOr<wire::UpdateResult> RemoteClient::UpdatePositions(
    const std::string& id, int64_t expected_generation, int dimension,
    const std::vector<Vec3>& positions, const std::vector<int32_t>& indices) {
  auto ctx = Context(id);
  v1::UpdatePositionsRequest req;
  req.set_session_id(id);
  req.set_expected_generation(expected_generation);
  req.mutable_indices()->Add(indices.begin(), indices.end());
  wire::AppendFlattened(positions, dimension, req.mutable_positions());
  v1::UpdatePositionsResponse resp;
  if (absl::Status s =
          Checked(stub_->UpdatePositions(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return wire::FromWire(resp);
}

absl::StatusOr<wire::SdfReply> RemoteClient::ComputeSdf(const std::string& id,
                                                        const SdfParams& params,
                                                        const SdfCall& call) {
  if (call.fan_out > 1 && params.range.all()) {
    if (call.mesh == nullptr) {
      return absl::InvalidArgumentError(
          "a fanned-out ComputeSdf needs the session's mesh (SdfCall::mesh)");
    }
    // Progress: the ranges' vertices done, summed.
    const int64_t samples = NumSamples(*call.mesh, params.samples);
    std::vector<int64_t> done(call.fan_out, 0);
    std::mutex progress_mu;
    auto parts = FanOut<wire::SdfReply>(
        samples, call.fan_out, [&](int index, SampleRange range) {
          SdfParams part = params;
          part.range = range;
          SdfCall range_call = call;
          range_call.fan_out = 1;
          range_call.part = index;
          if (call.progress) {
            range_call.progress = [&, index](int64_t d, int64_t) {
              std::lock_guard<std::mutex> lock(progress_mu);
              done[index] = d;
              int64_t sum = 0;
              for (int64_t x : done) sum += x;
              call.progress(sum, samples);
            };
          }
          return ComputeSdf(id, part, range_call);
        });
    if (!parts.ok()) return parts.status();
    return MergeSdfReplies(*call.mesh, std::move(*parts));
  }
  // The channel's retry policy retries a call until its reply has started;
  // a stream cut after that (its replica died: UNAVAILABLE, or UNKNOWN
  // "Stream removed" through the balancer) is asked again, a read being
  // safe to repeat.
  for (int attempt = 1;; ++attempt) {
    bool started = false;
    auto reply = ComputeSdfOnce(id, params, call, &started);
    const absl::StatusCode code = reply.status().code();
    if (reply.ok() || !options_.retry || !started || attempt == 3 ||
        (code != absl::StatusCode::kUnavailable &&
         code != absl::StatusCode::kUnknown)) {
      return reply;
    }
  }
}

absl::StatusOr<wire::SdfReply> RemoteClient::ComputeSdfOnce(
    const std::string& id, const SdfParams& params, const SdfCall& call,
    bool* started) {
  auto ctx = Context(id, params.range, call.part);
  v1::ComputeSdfRequest req;
  req.set_session_id(id);
  *req.mutable_params() = wire::ToWire(params);
  if (!params.range.all()) wire::ToWire(params.range, req.mutable_range());
  req.set_include_jacobian(call.include_jacobian);
  req.set_chunk_vertices(call.chunk_vertices);
  req.set_report_progress(call.progress != nullptr);
  if (call.expected_generation) {
    req.set_expected_generation(*call.expected_generation);
  }
  auto reader = stub_->ComputeSdf(ctx.get(), req);
  wire::SdfReply out;
  if (call.include_jacobian) out.jacobian.emplace();
  absl::Status parsed;
  bool summary = false;
  v1::ComputeSdfResponse msg;
  while (reader->Read(&msg)) {
    *started = true;
    if (!parsed.ok()) continue;  // drain the stream, keep the first error.
    if (msg.has_summary()) {
      parsed = wire::FinishReply(msg.summary(), params, &out);
      summary = true;
    } else if (msg.has_progress()) {
      if (call.progress) {
        call.progress(msg.progress().vertices_done(),
                      msg.progress().vertices_total());
      }
    } else {
      parsed = wire::AppendChunk(msg.chunk(), &out, params.range.begin);
    }
  }
  if (absl::Status s = Checked(reader->Finish()); !s.ok()) return s;
  if (!parsed.ok()) return parsed;
  if (!summary) {
    return absl::DataLossError("ComputeSdf stream ended without its summary");
  }
  return out;
}

absl::StatusOr<wire::GradCheckReply> RemoteClient::GradCheck(
    const std::string& id, const SdfParams& params,
    const GradCheckOptions& options,
    std::function<void(int64_t, int64_t)> progress) {
  auto ctx = Context(id);
  v1::GradCheckRequest req;
  req.set_session_id(id);
  *req.mutable_params() = wire::ToWire(params);
  wire::ToWire(options, &req);
  req.set_report_progress(progress != nullptr);
  auto reader = stub_->GradCheck(ctx.get(), req);
  std::optional<v1::GradCheckReport> report;
  v1::GradCheckResponse msg;
  while (reader->Read(&msg)) {
    if (msg.has_report()) {
      report = std::move(*msg.mutable_report());
    } else if (msg.has_progress() && progress) {
      progress(msg.progress().vertices_done(), msg.progress().vertices_total());
    }
  }
  if (absl::Status s = Checked(reader->Finish()); !s.ok()) return s;
  if (!report) {
    return absl::DataLossError("GradCheck stream ended without its report");
  }
  auto rep = wire::FromWire(*report);
  if (!rep.ok()) return rep.status();
  return wire::GradCheckReply{std::move(*rep),
                              {report->generation(), false, report->seconds()}};
}

template <typename Reply>
absl::StatusOr<std::vector<Reply>> RemoteClient::FanOut(
    int64_t samples, int fan_out,
    const std::function<absl::StatusOr<Reply>(int, SampleRange)>& call) {
  const std::vector<SampleRange> ranges = SplitSamples(samples, fan_out);
  std::vector<Reply> replies(ranges.size());
  absl::Status s = RunConcurrently(
      static_cast<int>(ranges.size()), [&](int i) -> absl::Status {
        for (int attempt = 1;; ++attempt) {
          auto reply = call(i, ranges[i]);
          if (reply.ok()) {
            replies[i] = std::move(*reply);
            return absl::OkStatus();
          }
          const absl::StatusCode code = reply.status().code();
          // The balancer sends the range again to a replica that is up.
          if (!options_.retry || attempt == 3 ||
              (code != absl::StatusCode::kUnavailable &&
               code != absl::StatusCode::kUnknown)) {
            return reply.status();
          }
        }
      });
  if (!s.ok()) return s;
  return replies;
}

absl::StatusOr<wire::VjpReply> RemoteClient::ComputeVjp(
    const std::string& id, const SdfParams& params,
    absl::Span<const double> weights,
    std::optional<int64_t> expected_generation, int fan_out) {
  if (fan_out <= 1 || !params.range.all()) {
    return ComputeVjpOnce(id, params, weights, expected_generation);
  }
  auto parts = FanOut<wire::VjpReply>(
      std::ssize(weights), fan_out, [&](int index, SampleRange range) {
        SdfParams part = params;
        part.range = range;
        return ComputeVjpOnce(
            id, part, weights.subspan(range.begin, range.end - range.begin),
            expected_generation, index);
      });
  if (!parts.ok()) return parts.status();
  if (parts->empty()) {  // no sample: the whole call's reply.
    return ComputeVjpOnce(id, params, weights, expected_generation);
  }
  const int64_t vertices = std::ssize(parts->front().sums) / 3;
  return MergeVjpReplies(vertices, *parts);
}

absl::StatusOr<wire::VjpReply> RemoteClient::ComputeVjpOnce(
    const std::string& id, const SdfParams& params,
    absl::Span<const double> weights,
    std::optional<int64_t> expected_generation, int part) {
  auto ctx = Context(id, params.range, part);
  v1::ComputeVjpRequest req;
  req.set_session_id(id);
  *req.mutable_params() = wire::ToWire(params);
  if (!params.range.all()) wire::ToWire(params.range, req.mutable_range());
  if (expected_generation) req.set_expected_generation(*expected_generation);
  req.mutable_weights()->Add(weights.begin(), weights.end());
  v1::ComputeVjpResponse resp;
  if (absl::Status s = Checked(stub_->ComputeVjp(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return wire::FromWire(resp);
}

absl::StatusOr<wire::PenaltyReply> RemoteClient::ComputePenalty(
    const std::string& id, const SdfParams& params,
    const PenaltyParams& penalty, bool with_gradient,
    std::optional<int64_t> expected_generation, int fan_out,
    absl::Span<const double> values) {
  if (fan_out <= 1 || !params.range.all()) {
    return ComputePenaltyOnce(id, params, penalty, with_gradient,
                              expected_generation, values, -1);
  }
  if (values.empty()) {
    return absl::InvalidArgumentError(
        "a fanned-out penalty needs every sample's value (from a fanned-out "
        "ComputeSdf of the same parameters)");
  }
  auto parts = FanOut<wire::PenaltyReply>(
      std::ssize(values), fan_out, [&](int index, SampleRange range) {
        SdfParams part = params;
        part.range = range;
        return ComputePenaltyOnce(id, part, penalty, with_gradient,
                                  expected_generation, values, index);
      });
  if (!parts.ok()) return parts.status();
  return MergePenaltyReplies(std::move(*parts), with_gradient);
}

absl::StatusOr<wire::PenaltyReply> RemoteClient::ComputePenaltyOnce(
    const std::string& id, const SdfParams& params,
    const PenaltyParams& penalty, bool with_gradient,
    std::optional<int64_t> expected_generation,
    absl::Span<const double> values, int part) {
  auto ctx = Context(id, params.range, part);
  v1::ComputePenaltyRequest req;
  req.set_session_id(id);
  *req.mutable_params() = wire::ToWire(params);
  wire::ToWire(penalty, &req);
  req.set_with_gradient(with_gradient);
  if (expected_generation) req.set_expected_generation(*expected_generation);
  if (!params.range.all()) {
    wire::ToWire(params.range, req.mutable_range());
    req.mutable_values()->Add(values.begin(), values.end());
  }
  v1::ComputePenaltyResponse resp;
  if (absl::Status s =
          Checked(stub_->ComputePenalty(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return wire::FromWire(resp, with_gradient);
}

absl::StatusOr<CalibrationReport> RemoteClient::Calibrate(
    const std::string& id, const CalibrationParams& params) {
  auto ctx = Context(id);
  v1::CalibrateRequest req;
  req.set_session_id(id);
  wire::ToWire(params, &req);
  v1::CalibrateResponse resp;
  if (absl::Status s = Checked(stub_->Calibrate(ctx.get(), req, &resp));
      !s.ok()) {
    return s;
  }
  return wire::FromWire(resp);
}

}  // namespace meshgauge::client

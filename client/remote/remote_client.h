// C++ client of the meshgauge gRPC service: library types in and out (the
// wire conversion is proto/wire/convert.h). Every call of a session carries
// the metadata `x-meshgauge-session: <id>` (the routing key of a session-
// affine balancer) and the client's deadline.
#pragma once

#include <grpcpp/grpcpp.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/core/calibration_types.h"
#include "lib/core/mesh.h"
#include "lib/core/penalty.h"
#include "lib/core/sdf_types.h"
#include "meshgauge/v1/meshgauge.grpc.pb.h"
#include "proto/wire/types.h"

namespace meshgauge::client {

inline constexpr char kSessionMetadataKey[] = "x-meshgauge-session";

inline constexpr char kAuthorizationMetadataKey[] = "authorization";

// A range call (SdfParams::range) also carries `x-meshgauge-range:
// BEGIN-END`, and a fanned-out call's range its index among the call's
// ranges, `x-meshgauge-part: I` (0, 1, ...): the balancer sends parts I and
// I + 1 of one session to different replicas while there are as many
// replicas as parts, and part I to the same replica from call to call
// (docs/deployment.md).
inline constexpr char kRangeMetadataKey[] = "x-meshgauge-range";
inline constexpr char kPartMetadataKey[] = "x-meshgauge-part";

struct ClientOptions {
  double deadline_seconds = 600;      // per call.
  int upload_chunk_vertices = 65536;  // vertices (and faces) per chunk.
  int64_t max_message_bytes = 256ll << 20;
  // Sent as `authorization: Bearer <token>` on every call when not empty.
  std::string token;
  // TLS when tls_ca_pem is set: the server must present a certificate signed
  // by this CA (PEM text, not a path); with tls_cert_pem and tls_key_pem the
  // client presents its own (mutual TLS).
  std::string tls_ca_pem, tls_cert_pem, tls_key_pem;
  // The channel's service config (proto/meshgauge/v1/service_config.json,
  // shared with the Python client): UNAVAILABLE (a
  // replica down, draining or restarting, Redis restarting) is retried up
  // to 5 attempts with exponential backoff (0.2 s to 3 s). UpdatePositions
  // is safe to retry: the server recognises an update it already applied
  // by its generation.
  bool retry = true;
  // Wait for ready, bounded: a call on a channel that is not connected
  // first waits this long (at most deadline_seconds) for the connection;
  // if it does not come (server down, wrong address, TLS mismatch) the call
  // fails UNAVAILABLE (after the retries) instead of waiting until its
  // deadline, as gRPC's own waitForReady would on a dead server.
  double connect_timeout_seconds = 20;
};

// A random (version 4) UUID: the id a client gives a session when the
// caller names none, so that every call, the upload included, carries its
// routing key.
std::string NewSessionId();

// ClientOptions' PEM fields from files (empty paths are skipped) and the
// token from a file (its first line) or, without one, from the
// MESHGAUGE_TOKEN environment variable. Errors: NotFound naming the file.
absl::Status LoadClientSecrets(const std::string& ca_file,
                               const std::string& cert_file,
                               const std::string& key_file,
                               const std::string& token_file,
                               ClientOptions* options);

// Options of one ComputeSdf call.
struct SdfCall {
  bool include_jacobian = false;  // also stream the sparse Jacobian rows.
  // If set, must equal the session's generation (else ABORTED).
  std::optional<int64_t> expected_generation = std::nullopt;
  int chunk_vertices = 0;  // vertices per message, 1..65536; 0: the server's.
  // If set, the server streams the ray pass's progress to it (vertices
  // done, vertices in all); not called when the server reuses a pass.
  std::function<void(int64_t done, int64_t total)> progress = nullptr;
  // Split the call into this many sample ranges sent at once (the fan-out,
  // docs/server.md; 1: one call). Needs `mesh`, the session's mesh at its
  // current positions: the merged reply's missing counts and integral are
  // computed from it (InvalidArgument without it).
  int fan_out = 1;
  const Mesh* mesh = nullptr;
  // Set by the fan-out on each range call: its index (x-meshgauge-part).
  int part = -1;
};

class RemoteClient {
 public:
  // `target` is host:port. The channel is insecure unless options carry a
  // TLS CA (then TLS, mutual with a client certificate).
  explicit RemoteClient(const std::string& target, ClientOptions options = {});

  // Uploads a mesh (validate it first for a clearer error) as a new session;
  // empty id: NewSessionId().
  absl::StatusOr<wire::SessionInfo> Upload(const Mesh& mesh,
                                           const std::string& session_id = "");
  // Every field of the session (does not reset its idle clock).
  absl::StatusOr<wire::SessionInfo> Get(const std::string& session_id);
  // All sessions (follows the pages).
  absl::StatusOr<std::vector<wire::SessionInfo>> List(int page_size = 100);
  absl::Status Delete(const std::string& session_id);
  // All positions (indices empty) or a subset; `dimension` values of each
  // point are sent. ABORTED when expected_generation is not the session's.
  absl::StatusOr<wire::UpdateResult> UpdatePositions(
      const std::string& session_id, int64_t expected_generation, int dimension,
      const std::vector<Vec3>& positions,
      const std::vector<int32_t>& indices = {});
  // The SDF of the session's current positions (the server picks the
  // threads). A stream cut after it started (UNAVAILABLE, UNKNOWN: its
  // replica died) is asked again, three attempts in all, with
  // options.retry; progress then starts again. With call.fan_out > 1 (and
  // no params.range) the samples are split into that many ranges, called
  // at once, each asked again up to three times when it fails UNAVAILABLE
  // or UNKNOWN, and merged: the whole call's reply, bit for bit. Errors:
  // the server's, DATA_LOSS for a malformed stream, ABORTED when the
  // session moved between the ranges.
  absl::StatusOr<wire::SdfReply> ComputeSdf(const std::string& session_id,
                                            const SdfParams& params,
                                            const SdfCall& call = {});
  // g^T J for per-sample weights g (#V or #F; with params.range, the
  // range's). With fan_out > 1 (and no params.range) split and merged as
  // ComputeSdf's: the exact partial sums of the ranges added and rounded
  // once, bit for bit the whole call's.
  absl::StatusOr<wire::VjpReply> ComputeVjp(
      const std::string& session_id, const SdfParams& params,
      absl::Span<const double> weights,
      std::optional<int64_t> expected_generation = std::nullopt,
      int fan_out = 1);
  // With fan_out > 1 (and no params.range): split into that many sample
  // ranges sent at once, each with `values`, every sample's value from a
  // fanned-out ComputeSdf of `params` (InvalidArgument without them), and
  // merged: the whole call's reply, bit for bit (MergePenaltyReplies).
  absl::StatusOr<wire::PenaltyReply> ComputePenalty(
      const std::string& session_id, const SdfParams& params,
      const PenaltyParams& penalty, bool with_gradient,
      std::optional<int64_t> expected_generation = std::nullopt,
      int fan_out = 1, absl::Span<const double> values = {});
  // The report without its per-vertex arrays (sdf, thickness stay empty).
  absl::StatusOr<CalibrationReport> Calibrate(const std::string& session_id,
                                              const CalibrationParams& params);

  // The SPEC §6 finite-difference check of the session's derivatives at
  // its current positions, run by the server on a private copy (the
  // session is not changed). `progress`, if set, receives the vertices done
  // over all the check's passes. Errors: the server's, DATA_LOSS for a
  // malformed reply.
  absl::StatusOr<wire::GradCheckReply> GradCheck(
      const std::string& session_id, const SdfParams& params,
      const GradCheckOptions& options,
      std::function<void(int64_t done, int64_t total)> progress = nullptr);

  // The server's release and the limits the caller meets (GetServerInfo).
  absl::StatusOr<wire::ServerInfo> GetServerInfo();

  // grpc.health.v1.Health/Check for the whole server: true when SERVING,
  // false when NOT_SERVING (draining). Errors: the call's status.
  absl::StatusOr<bool> Serving();

  // The raw stub, for messages the typed calls never send (malformed
  // uploads, out-of-range pages: the tests that play a hostile client).
  v1::MeshGauge::Stub& stub() { return *stub_; }
  // A context with the deadline and the session routing key (and the
  // range's and its part's, for a range call of a fan-out; part < 0: none).
  std::unique_ptr<grpc::ClientContext> Context(const std::string& session_id,
                                               SampleRange range = {},
                                               int part = -1) const;

 private:
  // One ComputeSdf call; *started is set once a reply message arrived.
  absl::StatusOr<wire::SdfReply> ComputeSdfOnce(const std::string& session_id,
                                                const SdfParams& params,
                                                const SdfCall& call,
                                                bool* started);

  // The fan-out's range calls: `samples` split `fan_out` ways (SplitSamples),
  // call(index, range) on every range at once, a range asked again (at most
  // three attempts) while it fails UNAVAILABLE or UNKNOWN.
  template <typename Reply>
  absl::StatusOr<std::vector<Reply>> FanOut(
      int64_t samples, int fan_out,
      const std::function<absl::StatusOr<Reply>(int, SampleRange)>& call);
  absl::StatusOr<wire::VjpReply> ComputeVjpOnce(
      const std::string& session_id, const SdfParams& params,
      absl::Span<const double> weights,
      std::optional<int64_t> expected_generation, int part = -1);
  absl::StatusOr<wire::PenaltyReply> ComputePenaltyOnce(
      const std::string& session_id, const SdfParams& params,
      const PenaltyParams& penalty, bool with_gradient,
      std::optional<int64_t> expected_generation,
      absl::Span<const double> values, int part);

  // The call's status; UNAVAILABLE names the target (no server, wrong
  // address, refused connection).
  absl::Status Checked(const grpc::Status& s) const;

  ClientOptions options_;
  std::string target_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::MeshGauge::Stub> stub_;
};

}  // namespace meshgauge::client
